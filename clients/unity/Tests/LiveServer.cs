// Starts `viestac serve` (the repository's .venv, the simulated rig) for the live tests, with an
// admin token registered through VIESTAC_ADMIN_TOKEN (docs/security.md), as the Python tests'
// harness does (server/launcher.py, start_server).
using System;
using System.Diagnostics;
using System.IO;
using System.Security.Cryptography;
using System.Text.RegularExpressions;
using System.Threading;

namespace Viestac.Client.Tests
{
    sealed class LiveServer : IDisposable
    {
        public readonly string Token;
        public int Port { get; private set; }
        public Uri Http { get { return new Uri("http://127.0.0.1:" + Port + "/"); } }
        public Uri Ws { get { return new Uri("ws://127.0.0.1:" + Port + "/ws"); } }
        readonly string _dataDir;
        Process _proc;
        readonly StringWriterQueue _output = new StringWriterQueue();

        public LiveServer()
        {
            var bytes = new byte[32];
            using (var rng = RandomNumberGenerator.Create()) rng.GetBytes(bytes);
            Token = Convert.ToBase64String(bytes).Replace('+', '-').Replace('/', '_').TrimEnd('=');
            _dataDir = Path.Combine(Path.GetTempPath(), "viestac-cs-" + Guid.NewGuid().ToString("N"));
            Directory.CreateDirectory(_dataDir);
        }

        /// <summary>Starts the server (on `port`, or a free one for 0), waits until healthy and takes the control lease.</summary>
        public void Start(int port = 0, double timeoutS = 60)
        {
            var root = TestPaths.Root;
            var psi = new ProcessStartInfo(Path.Combine(root, ".venv", "bin", "python"),
                "-m server.cli serve --port " + port + " --scenario contact-angle --log-level warning --tracker-udp off " +
                "--lease-ttl 86400 --overrun-threshold 10000 --no-login-link --data-dir " + _dataDir)
            {
                WorkingDirectory = root, UseShellExecute = false, RedirectStandardOutput = true, RedirectStandardError = true,
            };
            psi.EnvironmentVariables["VIESTAC_ADMIN_TOKEN"] = Token;
            _proc = Process.Start(psi);
            var found = new ManualResetEventSlim();
            int seen = 0;
            DataReceivedEventHandler onLine = (_, e) =>
            {
                if (e.Data == null) return;
                _output.Add(e.Data);
                var m = Regex.Match(e.Data, @"on https?://[^\s/]+:(\d+)/ ");
                if (m.Success && Interlocked.Exchange(ref seen, 1) == 0) { Port = int.Parse(m.Groups[1].Value); found.Set(); }
            };
            _proc.OutputDataReceived += onLine;
            _proc.ErrorDataReceived += onLine;
            _proc.BeginOutputReadLine();
            _proc.BeginErrorReadLine();
            var deadline = DateTime.UtcNow.AddSeconds(timeoutS);
            if (!found.Wait(TimeSpan.FromSeconds(timeoutS)))
            {
                Stop();
                throw new InvalidOperationException("the server did not print its URL; it said:\n" + _output);
            }
            using (var rest = new ViestacRest(Http, Token))
            {
                string health = "no answer";
                while (true)
                {
                    try
                    {
                        var answer = rest.Get("api/health").Result;
                        var body = answer.Body as System.Collections.Generic.Dictionary<string, object>;
                        health = Json.Write(answer.Body);
                        if (body != null && (string)body["status"] == "ok") break;
                    }
                    catch (AggregateException e) { health = e.InnerException.Message; }
                    if (DateTime.UtcNow > deadline) { Stop(); throw new InvalidOperationException("the server did not become healthy: " + health); }
                    Thread.Sleep(100);
                }
                TakeLease(rest);
            }
        }

        /// <summary>Holds the control lease with the admin token (only its holder drives the HIP or switches scenarios).</summary>
        public void TakeLease(ViestacRest rest)
        {
            var answer = rest.RequestLease().Result;
            var body = answer.Body as System.Collections.Generic.Dictionary<string, object>;
            // "held": a restarted server on the same data directory kept this token's lease
            if (!answer.Ok || body == null || ((string)body["status"] != "granted" && (string)body["status"] != "held"))
                throw new InvalidOperationException("lease not granted: HTTP " + answer.Status + " " + Json.Write(answer.Body));
        }

        /// <summary>SIGTERM, so that the server stops its loop and device host processes too.</summary>
        public void Stop()
        {
            if (_proc == null) return;
            try
            {
                if (!_proc.HasExited)
                {
                    using (var kill = Process.Start(new ProcessStartInfo("kill", "-TERM " + _proc.Id) { UseShellExecute = false })) kill.WaitForExit();
                    if (!_proc.WaitForExit(15000)) _proc.Kill();
                }
            }
            catch (InvalidOperationException) { /* already gone */ }
            _proc.Dispose();
            _proc = null;
        }

        public void Dispose()
        {
            Stop();
            try { Directory.Delete(_dataDir, true); } catch (IOException) { }
        }

        sealed class StringWriterQueue
        {
            readonly System.Collections.Generic.List<string> _lines = new System.Collections.Generic.List<string>();
            public void Add(string line) { lock (_lines) { _lines.Add(line); if (_lines.Count > 200) _lines.RemoveAt(0); } }
            public override string ToString() { lock (_lines) return string.Join("\n", _lines); }
        }
    }
}
