// ViestacConsole.exe: a quick check of a rig from another machine (runs under Mono). Connects with
// a token, prints the scene and the live state (HIP, proxy, contact, cues, loop telemetry), can
// drive a scripted tracker path, and with --bench prints the state rate and the decode cost.
using System;
using System.Globalization;
using System.Linq;
using System.Threading;
using Viestac.Client;

static class ViestacConsole
{
    const string Usage = @"usage: mono ViestacConsole.exe --url ws://HOST:PORT/ws [--token TOKEN] [--role observer|participant|operator]
                               [--seconds N] [--path arc|none] [--take-lease] [--bench] [--every SECONDS]
  --token       the access token (default: the VIESTAC_TOKEN environment variable)
  --path arc    sweep the HIP along the contact-angle dome (-70..70 degrees), needs the control lease
  --take-lease  request the control lease first (REST /api/lease; an admin or experimenter token)
  --bench       print the state frames received per second and the decode cost per frame (p50/p99/max;
                the first second is left out: JIT compilation)
  --decode-bench N   decode a state frame like the contact-angle scenario's N times, no server";

    static int Main(string[] args)
    {
        string url = null, token = Environment.GetEnvironmentVariable("VIESTAC_TOKEN"), role = Roles.Observer, path = "none";
        double seconds = 10, every = 0.5;
        bool bench = false, takeLease = false;
        for (int i = 0; i < args.Length; i++)
        {
            Func<string> next = () => i + 1 < args.Length ? args[++i] : throw new ArgumentException(args[i] + " needs a value");
            switch (args[i])
            {
                case "--url": url = next(); break;
                case "--token": token = next(); break;
                case "--role": role = next(); break;
                case "--seconds": seconds = double.Parse(next(), CultureInfo.InvariantCulture); break;
                case "--every": every = double.Parse(next(), CultureInfo.InvariantCulture); break;
                case "--path": path = next(); break;
                case "--bench": bench = true; break;
                case "--decode-bench": return DecodeBench(int.Parse(next(), CultureInfo.InvariantCulture));
                case "--take-lease": takeLease = true; break;
                default: Console.Error.WriteLine(Usage); return 2;
            }
        }
        if (url == null) { Console.Error.WriteLine(Usage); return 2; }
        if (path != "none" && role == Roles.Observer) role = Roles.Participant;
        var uri = new Uri(url);
        if (takeLease)
            using (var rest = new ViestacRest(ViestacRest.BaseOf(uri), token))
            {
                var answer = rest.RequestLease().Result;
                Console.WriteLine("lease: HTTP " + answer.Status + " " + Json.Write(answer.Body));
            }

        var session = new ViestacSession(new SessionOptions { Url = uri, Token = token, Role = role, ClientName = "viestac-console/0.1", MeasureDecode = bench });
        StateFrame last = new StateFrame();
        bool haveState = false;
        session.StatusChanged += (s, why) => Console.WriteLine("[" + s + "] " + why);
        session.Welcomed += w => Console.WriteLine(string.Format("welcome: client {0}, role {1}, server {2}, v{3}.{4}, state {5} Hz{6}", w.ClientId, w.Role, w.Server, w.V, w.Minor, w.StateHz,
            w.Identity == null ? "" : ", token " + w.Identity.TokenId + " (" + w.Identity.Role + ")"));
        session.SceneReceived += PrintScene;
        session.StateReceived += s => { s.CopyTo(last); haveState = true; };
        session.ErrorReceived += e => Console.WriteLine("error " + e.Code + ": " + e.Message);
        session.HealthReceived += h => Console.WriteLine("health: " + h.Status + string.Concat(h.Reasons.Select(r => "\n  " + r.Code + ": " + r.Message)));
        session.LeaseReceived += l => Console.WriteLine("lease: " + (l.Holder == null ? "free" : "held by " + l.Holder.Label + " (" + l.Holder.Role + ")") + ", " + l.Queue.Count + " waiting");
        session.Start();

        var clock = System.Diagnostics.Stopwatch.StartNew();
        double nextPrint = every, benchFrom = -1;
        long statesAtBenchStart = 0;
        while (clock.Elapsed.TotalSeconds < seconds)
        {
            session.Drain();
            double t = clock.Elapsed.TotalSeconds;
            if (path == "arc" && session.Status == ConnectionStatus.Connected)
            {
                double angle = -70 + 140 * (0.5 - 0.5 * Math.Cos(t * Math.PI / 4)); // 8 s there and back
                double r = 0.6 + 0.06 - 0.003, a = angle * Math.PI / 180;
                session.SendTracker(new Vec3(0, r * Math.Sin(a), r * Math.Cos(a)));
            }
            if (bench && benchFrom < 0 && haveState && t > 1) { benchFrom = t; statesAtBenchStart = session.StatesReceived; session.ResetDecodeTimes(); }
            if (!bench && haveState && t >= nextPrint) { nextPrint = t + every; PrintState(last); }
            Thread.Sleep(5);
        }
        if (bench) PrintBench(session, clock.Elapsed.TotalSeconds - benchFrom, session.StatesReceived - statesAtBenchStart);
        session.Dispose();
        return haveState ? 0 : 1;
    }

    /// <summary>The decode cost without a network: a state frame with the fields the contact-angle
    /// scenario sends in contact (one contact, a tilt cue, values, telemetry), decoded N times.</summary>
    static int DecodeBench(int n)
    {
        var frame = new System.Collections.Generic.Dictionary<string, object>
        {
            { "type", "state" }, { "frame", 123456L }, { "tick", 2057123L }, { "t", 26086.348123456 }, { "scene", "787b867bd84bf2b8" },
            { "hip", new object[] { 0L, -0.500123456, 0.425987654 } }, { "proxy", new object[] { 0L, -0.502412345, 0.427965432 } },
            { "force", new object[] { 0L, -2.283812, 1.945312 } }, { "contact", true },
            { "contacts", new object[] { new object[] { "hemisphere", new object[] { 0L, -0.761234, 0.648321 }, 0.003001234 } } },
            { "objects", new object[0] },
            { "cues", new object[] { new System.Collections.Generic.Dictionary<string, object> { { "kind", "tilt" }, { "direction_deg", 49.57561234 }, { "magnitude_pct", 100L } } } },
            { "hud", "Angle -50°" }, { "values", new System.Collections.Generic.Dictionary<string, object> { { "angle_deg", -49.57561234 }, { "in_contact", true } } },
            { "telemetry", new System.Collections.Generic.Dictionary<string, object> { { "period_p50_us", 1000.2 }, { "period_p99_us", 1084.7 }, { "period_max_us", 1520.1 }, { "overruns", 4L }, { "tick_cost_p99_us", 61.3 }, { "ticks", 2057123L }, { "rt", true } } },
            { "visible", new System.Collections.Generic.Dictionary<string, object>() }, { "events", new object[0] },
            { "driver", new object[] { 1L, 5123L } },
        };
        var w = new MsgPackWriter();
        w.WriteValue(frame);
        var bytes = w.ToArray();
        var reader = new MsgPackReader();
        var reuse = new StateFrame();
        var us = new double[n];
        for (int i = 0; i < 2000; i++) Protocol.Parse(reader.ReadFrame(bytes), reuse); // JIT and caches warm
        for (int i = 0; i < n; i++)
        {
            long start = System.Diagnostics.Stopwatch.GetTimestamp();
            Protocol.Parse(reader.ReadFrame(bytes), reuse);
            us[i] = (System.Diagnostics.Stopwatch.GetTimestamp() - start) * 1e6 / System.Diagnostics.Stopwatch.Frequency;
        }
        Array.Sort(us);
        Console.WriteLine(string.Format(CultureInfo.InvariantCulture, "decode-bench: {0}-byte state frame, {1} decodes: p50 {2:0.0} µs, p99 {3:0.0} µs, max {4:0.0} µs",
            bytes.Length, n, us[n / 2], us[Math.Min(n - 1, (int)(0.99 * n))], us[n - 1]));
        return 0;
    }

    static string F(double v) { return v.ToString("0.####", CultureInfo.InvariantCulture); }

    static void PrintScene(SceneMessage m)
    {
        var s = m.Scene;
        Console.WriteLine("scene '" + s.Name + "' hash " + m.Hash + ", camera " + s.Camera.Projection + " at " + s.Camera.Position + " → " + s.Camera.Target);
        foreach (var o in s.Objects)
            Console.WriteLine(string.Format("  {0,-16} {1,-10} at {2} k={3} N/m{4}{5}", o.Id, o.Shape.Type, o.Pos, F(o.Material.StiffnessNPerM),
                o.Haptic ? "" : " (not touched)", o.Visible ? "" : " (hidden)"));
        foreach (var o in s.Overlays) Console.WriteLine("  overlay " + o.Id + " (" + o.Kind + ")");
        foreach (var w in s.Warnings) Console.WriteLine("  warning: " + w);
    }

    static void PrintState(StateFrame s)
    {
        var cues = string.Join(" ", s.Cues.Select(c => c.Kind + "(" + string.Join(",", c.Fields.Select(kv => kv.Key + "=" + F(kv.Value))) + ")"));
        Console.WriteLine(string.Format("frame {0} t={1:0.000} hip {2} proxy {3} contact {4} force {5}{6}{7} | loop p99 {8:0} µs, overruns {9}, rt {10}",
            s.Frame, s.T, s.Hip, s.Proxy, s.Contact ? "yes" : "no", s.Force, cues.Length > 0 ? " cues " + cues : "",
            s.Hud.Length > 0 ? " hud \"" + s.Hud + "\"" : "", s.Telemetry.PeriodP99Us, s.Telemetry.Overruns, s.Telemetry.Rt));
        // v1.4: every tool (the primary first, the line above is it), the hand's other points, lost sources
        foreach (var tool in s.Tools)
            Console.WriteLine(string.Format("  tool {0,-20} hip {1} proxy {2} contact {3}{4}", tool.Name, tool.Hip, tool.Proxy,
                tool.Contact ? "yes" : "no", tool.Lost ? " LOST" : ""));
        if (s.Points.Count > 0)
            Console.WriteLine("  points " + string.Join(" ", s.Points.OrderBy(kv => kv.Key, StringComparer.Ordinal).Select(kv => kv.Key + " " + kv.Value)));
        if (s.TrackingLost.Count > 0) Console.WriteLine("  tracking lost: " + string.Join(", ", s.TrackingLost.Select(x => x.ToString())));
    }

    static void PrintBench(ViestacSession session, double seconds, long states)
    {
        var us = session.DecodeTimesUs();
        Array.Sort(us);
        Func<double, double> q = p => us.Length == 0 ? double.NaN : us[Math.Min(us.Length - 1, (int)Math.Ceiling(p * us.Length) - 1)];
        Console.WriteLine(string.Format(CultureInfo.InvariantCulture, "bench: {0} state frames in {1:0.0} s = {2:0.0} frames/s; decode per frame (msgpack + typed parse, {3} frames): p50 {4:0.0} µs, p99 {5:0.0} µs, max {6:0.0} µs",
            states, seconds, states / seconds, us.Length, q(0.5), q(0.99), us.Length == 0 ? double.NaN : us[us.Length - 1]));
    }
}
