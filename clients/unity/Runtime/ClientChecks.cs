// The checks the server makes of a client's message (docs/protocol.md "Client → server",
// "Bounds"), made before sending: a bad tracker sample or input fails here, with the code the
// server would answer, instead of costing an error frame. Tested against every refused frame of
// tests/vectors/invalid.json.
using System;
using System.Collections.Generic;

namespace Viestac.Client
{
    public static class ClientChecks
    {
        public const int MaxClientName = 64, MaxToken = 200, MaxKey = 32, MaxValueText = 200;

        /// <summary>Checks a decoded client message; throws ProtocolException with the server's code.</summary>
        public static void Check(object decoded)
        {
            var m = decoded as Dictionary<string, object>;
            if (m == null) throw Protocol.Bad("a message is a map");
            var type = Protocol.Field(m, "type") as string;
            if (type == null) throw Protocol.Bad("a message has a string `type`");
            switch (type)
            {
                case "hello":
                    long v = Protocol.AsInt(Protocol.Field(m, "v"), "hello.v", long.MinValue);
                    CheckHello(Protocol.Field(m, "role") as string, Protocol.Field(m, "client"), Protocol.Field(m, "token"));
                    if (v != Protocol.Version) throw new ProtocolException("unsupported_version", "this server speaks protocol v1");
                    break;
                case "tracker":
                {
                    long seq = Protocol.AsInt(Protocol.Field(m, "seq"), "tracker.seq", 0);
                    var t = Protocol.Field(m, "t");
                    double tMs = Protocol.AsNum(t, "tracker.t");
                    var pos = Protocol.Vec(Protocol.Field(m, "pos"), "tracker.pos");
                    var quat = Protocol.Field(m, "quat");
                    Quat? q = null;
                    if (quat != null)
                    {
                        var a = quat as List<object>;
                        if (a == null || a.Count != 4) throw Protocol.Bad("tracker.quat is [w, x, y, z]");
                        q = new Quat(Protocol.AsNum(a[0], "tracker.quat"), Protocol.AsNum(a[1], "tracker.quat"),
                                     Protocol.AsNum(a[2], "tracker.quat"), Protocol.AsNum(a[3], "tracker.quat"));
                    }
                    CheckTracker(seq, tMs, pos, q);
                    var sample = new Tracker { Seq = seq, TMs = tMs, Pos = pos, Quat = q };
                    var point = Protocol.Field(m, "point");
                    if (point != null)
                    {
                        sample.Point = point as string;
                        if (sample.Point == null) throw Protocol.Bad("tracker.point is a point name");
                    }
                    var points = Protocol.Field(m, "points");
                    if (points != null)
                    {
                        var map = points as Dictionary<string, object>;
                        if (map == null) throw Protocol.Bad("tracker.points is a map point name → [x, y, z]");
                        sample.Points = new List<PointPos>(map.Count);
                        foreach (var kv in map)
                        {
                            if (!TrackedPoints.IsPointName(kv.Key)) throw Protocol.Bad("tracker.points key '" + kv.Key + "' is not a point name");
                            sample.Points.Add(new PointPos(kv.Key, Protocol.Vec(kv.Value, "tracker.points")));
                        }
                    }
                    var ttl = Protocol.Field(m, "ttl");
                    if (ttl != null) sample.TtlMs = Protocol.AsNum(ttl, "tracker.ttl");
                    CheckTrackerV14(sample.Point, sample.Points, sample.TtlMs);
                    break;
                }
                case "input":
                    CheckInput(Protocol.Field(m, "key") as string, Protocol.Field(m, "action") as string, Protocol.Field(m, "value"));
                    break;
                case "answer":
                    CheckAnswer(Protocol.AsInt(Protocol.Field(m, "seq"), "answer.seq", 0), Protocol.Field(m, "question") as string,
                                Protocol.Field(m, "value"));
                    break;
                case "actuators":
                    CheckActuators(Protocol.Field(m, "actuators") as List<object>, Protocol.Field(m, "note"));
                    break;
                default: throw new ProtocolException("unknown_type", "no client message of type '" + type + "'");
            }
        }

        public static void CheckHello(string role, object client, object token)
        {
            if (role != Roles.Participant && role != Roles.Operator && role != Roles.Observer)
                throw Protocol.Bad("hello.role is participant, operator or observer");
            if (client != null && !(client is string && CodePoints((string)client) <= MaxClientName))
                throw Protocol.Bad("hello.client is a string of at most 64 characters");
            if (token != null && !(token is string && CodePoints((string)token) <= MaxToken))
                throw Protocol.Bad("hello.token is a string of at most 200 characters");
        }

        public static void CheckTracker(long seq, double tMs, Vec3 pos, Quat? quat)
        {
            if (seq < 0) throw Protocol.Bad("tracker.seq is ≥ 0");
            if (seq > Protocol.MaxSafeInteger) throw new ProtocolException("out_of_range", "tracker.seq is beyond 2^53 − 1");
            if (double.IsNaN(tMs) || double.IsInfinity(tMs) || double.IsNaN(pos.X + pos.Y + pos.Z) || double.IsInfinity(pos.X + pos.Y + pos.Z))
                throw new ProtocolException("non_finite", "NaN or Infinity in a number");
            if (Math.Abs(tMs) > Protocol.MaxSafeInteger) throw new ProtocolException("out_of_range", "tracker.t is beyond ±(2^53 − 1) ms");
            double h = Protocol.WorkspaceHalfExtent;
            if (Math.Abs(pos.X) > h || Math.Abs(pos.Y) > h || Math.Abs(pos.Z) > h)
                throw new ProtocolException("out_of_range", "tracker.pos lies outside the workspace (±10 scene units)");
            if (quat.HasValue)
            {
                double n = quat.Value.Norm;
                if (double.IsNaN(n) || double.IsInfinity(n)) throw new ProtocolException("non_finite", "NaN or Infinity in a number");
                if (!(n >= 0.5 && n <= 2)) throw Protocol.Bad("tracker.quat has a norm in [0.5, 2]");
            }
        }

        /// <summary>A whole `tracker` sample: CheckTracker and the v1.4 fields.</summary>
        public static void CheckTracker(Tracker t)
        {
            CheckTracker(t.Seq, t.TMs, t.Pos, t.Quat);
            CheckTrackerV14(t.Point, t.Points, t.TtlMs);
        }

        /// <summary>v1.4: `point` a point name, `points` point names within the workspace, `ttl` in [1, 10000] ms.</summary>
        public static void CheckTrackerV14(string point, IList<PointPos> points, double? ttlMs)
        {
            if (point != null && !TrackedPoints.IsPointName(point)) throw Protocol.Bad("tracker.point is a point name (HAND.wrist, HAND.palm or HAND.FINGER.JOINT)");
            if (points != null)
            {
                for (int i = 0; i < points.Count; i++) CheckPoint(points[i].Name, points[i].Pos);
                for (int i = 1; i < points.Count; i++)
                    for (int j = 0; j < i; j++)
                        if (points[i].Name == points[j].Name) throw Protocol.Bad("tracker.points names each point once");
            }
            if (ttlMs.HasValue)
            {
                double ttl = ttlMs.Value;
                if (double.IsNaN(ttl) || double.IsInfinity(ttl)) throw new ProtocolException("non_finite", "NaN or Infinity in a number");
                if (!(ttl >= MinTtlMs && ttl <= MaxTtlMs)) throw Protocol.Bad("tracker.ttl is in [1, 10000] ms");
            }
        }

        /// <summary>One tracked point: a point name, finite, inside the workspace.</summary>
        public static void CheckPoint(string name, Vec3 v)
        {
            if (!TrackedPoints.IsPointName(name)) throw Protocol.Bad("tracker.points keys are point names");
            if (double.IsNaN(v.X + v.Y + v.Z) || double.IsInfinity(v.X + v.Y + v.Z)) throw new ProtocolException("non_finite", "NaN or Infinity in a number");
            double h = Protocol.WorkspaceHalfExtent;
            if (Math.Abs(v.X) > h || Math.Abs(v.Y) > h || Math.Abs(v.Z) > h)
                throw new ProtocolException("out_of_range", "tracker.points lie inside the workspace (±10 scene units)");
        }

        public const double MinTtlMs = 1.0, MaxTtlMs = 10000.0;

        public static void CheckInput(string key, string action, object value)
        {
            if (key == null || CodePoints(key) < 1 || CodePoints(key) > MaxKey) throw Protocol.Bad("input.key is a string of 1..32 characters");
            if (action != InputActions.Down && action != InputActions.Up && action != InputActions.Press)
                throw Protocol.Bad("input.action is down, up or press");
            if (value == null || value is bool) return;
            CheckNumberOrText(value, "input.value", "a number, a bool or a string");
        }

        /// <summary>v1.5 `answer`: a trial, a question id of 1..64 characters, a number or a string ≤ 200.</summary>
        public static void CheckAnswer(long seq, string question, object value)
        {
            if (seq < 0) throw Protocol.Bad("answer.seq is an int >= 0");
            if (question == null || CodePoints(question) < 1 || CodePoints(question) > 64)
                throw Protocol.Bad("answer.question is a string of 1..64 characters");
            CheckNumberOrText(value, "answer.value", "a number or a string");
        }

        static readonly string[] ActuatorKinds = { "xr", "gamepad" };
        static readonly string[] Hands = { "left", "right", "none" };

        /// <summary>v1.6 `actuators`: an array of [kind, hand] pairs, and an optional note of at most 200 characters.</summary>
        public static void CheckActuators(IList<object> actuators, object note)
        {
            if (actuators == null) throw Protocol.Bad("actuators.actuators is an array of [kind, hand]");
            foreach (var item in actuators)
            {
                var pair = item as IList<object>;
                if (pair == null || pair.Count != 2 || Array.IndexOf(ActuatorKinds, pair[0] as string) < 0
                    || Array.IndexOf(Hands, pair[1] as string) < 0)
                    throw Protocol.Bad("actuators.actuators is an array of [\"xr\" | \"gamepad\", \"left\" | \"right\" | \"none\"]");
            }
            if (note != null && (!(note is string) || CodePoints((string)note) > MaxValueText))
                throw Protocol.Bad("actuators.note is a string of at most 200 characters");
        }

        /// <summary>A finite number, or a string of at most 200 characters (`input` and `answer` values).</summary>
        static void CheckNumberOrText(object value, string field, string kinds)
        {
            if (value is long || value is int) return;
            if (value is double || value is float)
            {
                double d = Convert.ToDouble(value);
                if (double.IsNaN(d) || double.IsInfinity(d)) throw new ProtocolException("non_finite", "NaN or Infinity in a number");
                return;
            }
            var s = value as string;
            if (s == null) throw Protocol.Bad(field + " is " + kinds);
            if (CodePoints(s) > MaxValueText) throw Protocol.Bad(field + " is at most 200 characters");
        }

        /// <summary>Unicode code points (the protocol counts them; C# strings count UTF-16 units).</summary>
        public static int CodePoints(string s)
        {
            int n = 0;
            foreach (char c in s) if (!char.IsLowSurrogate(c)) n++;
            return n;
        }
    }
}
