using System.IO;
using System.Linq;
using NUnit.Framework;

namespace Viestac.Client.Tests
{
    [TestFixture]
    public class PackageTests
    {
        static string Package { get { return Path.Combine(TestPaths.Root, "clients", "unity"); } }

        static bool Hidden(string name) { return name.StartsWith(".") || name.EndsWith("~"); }

        [Test]
        public void EveryAssetHasAMetaFileSoAGitInstallKeepsIt()
        {
            var missing = new System.Collections.Generic.List<string>();
            Walk(Package, missing);
            Assert.IsEmpty(missing, "run python3 clients/unity/meta.py");
        }

        static void Walk(string dir, System.Collections.Generic.List<string> missing)
        {
            foreach (var entry in Directory.GetFileSystemEntries(dir))
            {
                var name = Path.GetFileName(entry);
                if (Hidden(name) || name.EndsWith(".meta")) continue;
                if (!File.Exists(entry + ".meta")) missing.Add(entry.Substring(Package.Length + 1));
                if (Directory.Exists(entry)) Walk(entry, missing);
            }
        }

        [Test]
        public void TheCoreNeverReferencesUnityEngine()
        {
            var core = Directory.GetFiles(Path.Combine(Package, "Runtime"), "*.cs").Where(f => System.Text.RegularExpressions.Regex.IsMatch(File.ReadAllText(f), @"\busing\s+UnityEngine|UnityEngine\.\w")).ToList();
            Assert.IsEmpty(core, "the core compiles without Unity; only Runtime/Unity uses it");
            var unity = typeof(ViestacSession).Assembly.GetReferencedAssemblies().Select(a => a.Name).ToList();
            CollectionAssert.DoesNotContain(unity, "UnityEngine");
            // what .NET Standard 2.0 (and so Unity 2021+) provides: no Mono-only assembly
            CollectionAssert.IsSubsetOf(unity, new[] { "mscorlib", "System", "System.Core", "System.Net.Http", "System.Numerics" });
        }

        [Test]
        public void TheReadmeExampleIsTheCompiledSample()
        {
            var readme = File.ReadAllText(Path.Combine(Package, "README.md"));
            var sample = File.ReadAllText(Path.Combine(Package, "Samples~", "MinimalViewer", "MinimalViewer.cs"));
            var body = sample.Substring(sample.IndexOf("using UnityEngine;")).Trim();
            StringAssert.Contains(body, readme.Replace("\r\n", "\n"));
        }
    }
}
