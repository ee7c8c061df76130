using System;
using System.IO;

namespace Viestac.Client.Tests
{
    static class TestPaths
    {
        /// <summary>The repository root: VIESTAC_ROOT, else found upward from the test assembly (clients/unity/.build/).</summary>
        public static string Root
        {
            get
            {
                var env = Environment.GetEnvironmentVariable("VIESTAC_ROOT");
                if (!string.IsNullOrEmpty(env)) return env;
                var dir = Path.GetDirectoryName(typeof(TestPaths).Assembly.Location);
                while (dir != null && !File.Exists(Path.Combine(dir, "docs", "protocol.md"))) dir = Path.GetDirectoryName(dir);
                if (dir == null) throw new InvalidOperationException("cannot find the repository root; set VIESTAC_ROOT");
                return dir;
            }
        }

        public static object LoadVectors(string name)
        {
            return Json.Parse(File.ReadAllText(Path.Combine(Root, "tests", "vectors", name)));
        }

        public static byte[] Hex(string hex)
        {
            var b = new byte[hex.Length / 2];
            for (int i = 0; i < b.Length; i++) b[i] = Convert.ToByte(hex.Substring(2 * i, 2), 16);
            return b;
        }

        public static string ToHex(byte[] b) { return BitConverter.ToString(b).Replace("-", "").ToLowerInvariant(); }
    }
}
