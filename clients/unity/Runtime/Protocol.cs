// Encoding of client messages and decoding (with the checks a client makes) of server messages:
// docs/protocol.md. Field order is the order the tables list, so the bytes match the vectors.
using System;
using System.Collections.Generic;

namespace Viestac.Client
{
    public static class Protocol
    {
        public const int Version = 1;
        public const string MsgPackSubprotocol = "viestac.v1.msgpack";
        public const double MaxSafeInteger = 9007199254740991.0; // 2^53 − 1
        public const double WorkspaceHalfExtent = 10.0;          // tracker.pos bound, scene units

        // ---- client → server ------------------------------------------------------------

        public static void WriteHello(MsgPackWriter w, string role, string client, string token)
        {
            w.WriteMapHeader(token == null ? 4 : 5);
            w.WriteString("type"); w.WriteString("hello");
            w.WriteString("v"); w.WriteInt(Version);
            w.WriteString("role"); w.WriteString(role);
            w.WriteString("client"); w.WriteString(client ?? "");
            if (token != null) { w.WriteString("token"); w.WriteString(token); }
        }

        /// <summary>`tracker`: `tMs` on the sender's clock, `pos` in the scene frame (inside the
        /// ±10 workspace or the server answers out_of_range), `quat` optional.</summary>
        public static void WriteTracker(MsgPackWriter w, long seq, double tMs, Vec3 pos, Quat? quat)
        {
            WriteTracker(w, seq, tMs, pos, quat, null, null, null);
        }

        /// <summary>`tracker` of protocol v1.4 (`Seq` as given; `Point`, `Points`, `TtlMs` when set).</summary>
        public static void WriteTracker(MsgPackWriter w, Tracker t)
        {
            WriteTracker(w, t.Seq, t.TMs, t.Pos, t.Quat, t.Point, t.Points, t.TtlMs);
        }

        static void WriteTracker(MsgPackWriter w, long seq, double tMs, Vec3 pos, Quat? quat, string point, List<PointPos> points, double? ttlMs)
        {
            w.WriteMapHeader(4 + (quat.HasValue ? 1 : 0) + (point != null ? 1 : 0) + (points != null ? 1 : 0) + (ttlMs.HasValue ? 1 : 0));
            w.WriteString("type"); w.WriteString("tracker");
            w.WriteString("seq"); w.WriteInt(seq);
            w.WriteString("t"); w.WriteNumber(tMs);
            w.WriteString("pos"); WriteVec(w, pos);
            if (quat.HasValue)
            {
                var q = quat.Value;
                w.WriteString("quat"); w.WriteArrayHeader(4);
                w.WriteNumber(q.W); w.WriteNumber(q.X); w.WriteNumber(q.Y); w.WriteNumber(q.Z);
            }
            if (point != null) { w.WriteString("point"); w.WriteString(point); }
            if (points != null)
            {
                w.WriteString("points"); w.WriteMapHeader(points.Count);
                for (int i = 0; i < points.Count; i++) { w.WriteString(points[i].Name); WriteVec(w, points[i].Pos); }
            }
            if (ttlMs.HasValue) { w.WriteString("ttl"); w.WriteNumber(ttlMs.Value); }
        }

        static void WriteVec(MsgPackWriter w, Vec3 v)
        {
            w.WriteArrayHeader(3); w.WriteNumber(v.X); w.WriteNumber(v.Y); w.WriteNumber(v.Z);
        }

        /// <summary>`input`: `value` is null (none), a number, a bool or a string.</summary>
        public static void WriteInput(MsgPackWriter w, string key, string action, object value)
        {
            w.WriteMapHeader(value == null ? 3 : 4);
            w.WriteString("type"); w.WriteString("input");
            w.WriteString("key"); w.WriteString(key);
            w.WriteString("action"); w.WriteString(action);
            if (value != null) { w.WriteString("value"); w.WriteValue(value); }
        }

        /// <summary>v1.5: a participant's answer to a question of its session's running trial (`ask`).
        /// `value` is a number or a string.</summary>
        public static void WriteAnswer(MsgPackWriter w, long seq, string question, object value)
        {
            w.WriteMapHeader(4);
            w.WriteString("type"); w.WriteString("answer");
            w.WriteString("seq"); w.WriteInt(seq);
            w.WriteString("question"); w.WriteString(question);
            w.WriteString("value"); w.WriteValue(value);
        }

        /// <summary>v1.6: the actuators this client can drive, each a [kind, hand] pair (kind "xr" or
        /// "gamepad", hand "left", "right" or "none"); none with a `note` saying why. The server's
        /// `state.actuator` then says what they play (this client does not drive any yet).</summary>
        public static void WriteActuators(MsgPackWriter w, IList<string[]> actuators, string note = null)
        {
            w.WriteMapHeader(string.IsNullOrEmpty(note) ? 2 : 3);
            w.WriteString("type"); w.WriteString("actuators");
            w.WriteString("actuators"); w.WriteArrayHeader(actuators.Count);
            foreach (var a in actuators) { w.WriteArrayHeader(2); w.WriteString(a[0]); w.WriteString(a[1]); }
            if (!string.IsNullOrEmpty(note)) { w.WriteString("note"); w.WriteString(note); }
        }

        // ---- server → client ------------------------------------------------------------

        /// <summary>A decoded frame as a typed message; null for a type this client does not know
        /// (receivers ignore them). `state` fills `reuse` when given. Throws ProtocolException.</summary>
        public static ServerMessage Parse(object decoded, StateFrame reuse = null)
        {
            var m = decoded as Dictionary<string, object>;
            if (m == null) throw Bad("a message is a map");
            var type = Field(m, "type") as string;
            if (type == null) throw Bad("a message has a string `type`");
            switch (type)
            {
                case "welcome": return ParseWelcome(m);
                case "scene": return ParseScene(m);
                case "state": return ParseState(m, reuse ?? new StateFrame());
                case "error":
                    return new ErrorMessage { Code = Str(m, "error", "code"), Message = Str(m, "error", "message") };
                case "health": return ParseHealth(m);
                case "lease": return ParseLease(m);
                case "ask": return ParseAsk(m);
                default: return null;
            }
        }

        /// <summary>Decodes and checks one frame. A `state` is read straight into `reuse` (no tree,
        /// no allocation in steady state); other messages through the plain-object tree.</summary>
        public static ServerMessage Decode(MsgPackReader r, byte[] buf, int offset, int count, StateFrame reuse)
        {
            r.Begin(buf, offset, count);
            if (reuse != null && PeekType(r) == "state")
            {
                try
                {
                    r.Begin(buf, offset, count);
                    StateReader.Read(r, reuse);
                    r.EndFrame();
                    return reuse;
                }
                catch (ProtocolException e) when (e.Code == "bad_message")
                {
                    // The whole frame's encoding errors (non_finite, bad_encoding) come first, as
                    // for the server's codec: the tree reader finds them, or the refusal stands.
                    r.ReadFrame(buf, offset, count);
                    throw;
                }
            }
            return Parse(r.ReadFrame(buf, offset, count), reuse);
        }

        /// <summary>The `type` of the map at the cursor (encoders write it first), or null.</summary>
        static string PeekType(MsgPackReader r)
        {
            try
            {
                if (!r.IsMap) return null;
                int n = r.ReadMapHeader("a message");
                for (int i = 0; i < n; i++)
                {
                    if (!r.IsString) return null;
                    var key = r.ReadString("a key");
                    if (key == "type") return r.IsString ? r.ReadString("type") : null;
                    r.Skip(1);
                }
            }
            catch (ProtocolException) { /* the tree reader reports it */ }
            return null;
        }

        static Welcome ParseWelcome(Dictionary<string, object> m)
        {
            var w = new Welcome
            {
                V = Int(m, "welcome", "v", long.MinValue),
                ClientId = Int(m, "welcome", "client_id", 1),
                Role = OneOf(m, "welcome", "role", Roles.Participant, Roles.Operator, Roles.Observer),
                Server = Str(m, "welcome", "server"),
                TickHz = Int(m, "welcome", "tick_hz", 1),
                StateHz = Positive(m, "welcome", "state_hz"),
                Format = OneOf(m, "welcome", "format", "msgpack", "json"),
            };
            if (Field(m, "minor") != null) w.Minor = Int(m, "welcome", "minor", 0);
            var identity = Field(m, "identity");
            if (identity != null)
            {
                var id = identity as Dictionary<string, object>;
                if (id == null) throw Bad("welcome.identity is a map");
                w.Identity = new Identity
                {
                    TokenId = OptStr(id, "welcome.identity", "token_id"), Role = OptStr(id, "welcome.identity", "role"),
                    Site = OptStr(id, "welcome.identity", "site"), Session = OptStr(id, "welcome.identity", "session"),
                };
            }
            return w;
        }

        static SceneMessage ParseScene(Dictionary<string, object> m)
        {
            var raw = Field(m, "scene") as Dictionary<string, object>;
            if (raw == null) throw Bad("scene.scene is a map");
            var hash = Str(m, "scene", "hash");
            return new SceneMessage { V = Int(m, "scene", "v", 1), Hash = hash, Raw = raw, Scene = Scene.FromMap(raw), HashVerified = SceneHash.Of(raw) == hash };
        }

        static StateFrame ParseState(Dictionary<string, object> m, StateFrame s)
        {
            const string at = "state";
            s.Reset();
            s.Frame = Int(m, at, "frame", 0);
            s.Tick = Int(m, at, "tick", 0);
            s.T = Num(m, at, "t");
            s.SceneHash = Str(m, at, "scene");
            s.Hip = Vec(Field(m, "hip"), "state.hip");
            s.Proxy = Vec(Field(m, "proxy"), "state.proxy");
            s.Force = Vec(Field(m, "force"), "state.force");
            var contact = Field(m, "contact");
            if (!(contact is bool)) throw Bad("state.contact is a bool");
            s.Contact = (bool)contact;
            foreach (var e in List(m, at, "contacts"))
            {
                var c = e as List<object>;
                if (c == null || c.Count != 3 || !(c[0] is string)) throw Bad("state.contacts[n] is [object_id, [nx, ny, nz], depth]");
                double depth = AsNum(c[2], "state.contacts[n][2]");
                if (depth < 0) throw Bad("state.contacts[n] depth is ≥ 0");
                s.Contacts.Add(new Contact { ObjectId = (string)c[0], Normal = Vec(c[1], "state.contacts[n][1]"), Depth = depth });
            }
            foreach (var e in List(m, at, "objects"))
            {
                var o = e as List<object>;
                if (o == null || o.Count != 3 || !(o[0] is string)) throw Bad("state.objects[n] is [object_id, [x, y, z], [w, x, y, z]]");
                s.Objects.Add(new ObjectPose { Id = (string)o[0], Pos = Vec(o[1], "state.objects[n][1]"), Rot = UnitQuat(o[2], "state.objects[n][2]") });
            }
            foreach (var e in List(m, at, "cues"))
            {
                var c = e as Dictionary<string, object>;
                if (c == null || !(Field(c, "kind") is string)) throw Bad("state.cues[n] is a map with a string `kind`");
                var cue = s.RentCue();
                cue.Kind = (string)c["kind"];
                foreach (var kv in c)
                    if (kv.Value is long || kv.Value is double) cue.Fields[kv.Key] = Convert.ToDouble(kv.Value);
                s.Cues.Add(cue);
            }
            s.Hud = Str(m, at, "hud");
            foreach (var kv in Map(m, at, "values", true)) s.Values[kv.Key] = kv.Value;
            var tel = Map(m, at, "telemetry", true);
            s.Telemetry = new Telemetry
            {
                PeriodP50Us = TelNum(tel, "period_p50_us"), PeriodP99Us = TelNum(tel, "period_p99_us"),
                PeriodMaxUs = TelNum(tel, "period_max_us"), TickCostP99Us = TelNum(tel, "tick_cost_p99_us"),
                Overruns = (long)TelNum(tel, "overruns"), Ticks = (long)TelNum(tel, "ticks"),
                Rt = Field(tel, "rt") is bool && (bool)tel["rt"],
            };
            foreach (var kv in Map(m, at, "visible", false)) s.Visible[kv.Key] = Bool(kv.Value, "state.visible");
            foreach (var e in OptList(m, at, "events"))
            {
                var ev = e as Dictionary<string, object>;
                if (ev == null) throw Bad("state.events[n] is a map");
                s.Events.Add(ev);
            }
            foreach (var kv in Map(m, at, "scales", false)) s.Scales[kv.Key] = Vec(kv.Value, "state.scales");
            foreach (var kv in Map(m, at, "stiffness", false))
            {
                double k = AsNum(kv.Value, "state.stiffness");
                if (k < 0) throw Bad("state.stiffness values are ≥ 0");
                s.Stiffness[kv.Key] = k;
            }
            foreach (var kv in Map(m, at, "haptic", false)) s.Haptic[kv.Key] = Bool(kv.Value, "state.haptic");
            var driver = Field(m, "driver");
            if (driver != null)
            {
                var d = driver as List<object>;
                if (d == null || d.Count != 2) throw Bad("state.driver is [client_id, seq] or null");
                s.HasDriver = true;
                if (d[0] is string) s.DriverBridge = (string)d[0];
                else s.DriverClientId = AsInt(d[0], "state.driver[0]", 1);
                s.DriverSeq = AsInt(d[1], "state.driver[1]", 0);
            }
            foreach (var e in OptList(m, at, "tools"))
            {
                var t = e as Dictionary<string, object>;
                if (t == null) throw Bad("state.tools[n] is a map {name, hip, proxy, contact, lost}");
                s.Tools.Add(new ToolState
                {
                    Name = Str(t, "state.tools[n]", "name"), Hip = Vec(Field(t, "hip"), "state.tools[n].hip"),
                    Proxy = Vec(Field(t, "proxy"), "state.tools[n].proxy"),
                    Contact = OptBool(t, "contact", "state.tools[n].contact"), Lost = OptBool(t, "lost", "state.tools[n].lost"),
                });
            }
            foreach (var kv in Map(m, at, "points", false))
            {
                if (!TrackedPoints.IsPointName(kv.Key)) throw Bad("state.points keys are point names");
                s.Points[kv.Key] = Vec(kv.Value, "state.points");
            }
            var tracking = Map(m, at, "tracking", false);
            foreach (var e in OptList(tracking, "state.tracking", "lost")) s.TrackingLost.Add(Source(e, "state.tracking.lost[n]"));
            var actuator = Field(m, "actuator");
            if (actuator != null)
            {
                var a = actuator as List<object>;
                if (a == null || a.Count != 5) throw Bad(ActuatorShape);
                for (int k = 0; k < 5; k++) s.Actuator[k] = AsNum(a[k], "state.actuator");
                CheckActuator(s.Actuator);
                s.HasActuator = true;
            }
            return s;
        }

        internal const string ActuatorShape = "state.actuator is [value 0..1, on_ms, off_ms, duration_ms, onset]";

        /// <summary>v1.6 `state.actuator`: value in [0, 1], the times ≥ 0, the onset a tick (an int ≥ 0).</summary>
        internal static void CheckActuator(double[] a)
        {
            if (a[0] < 0 || a[0] > 1 || a[1] < 0 || a[2] < 0 || a[3] < 0 || a[4] < 0 || a[4] != Math.Floor(a[4]))
                throw Bad(ActuatorShape);
        }

        static bool OptBool(Dictionary<string, object> m, string key, string what)
        {
            var v = Field(m, key);
            if (v == null) return false;
            if (!(v is bool)) throw Bad(what + " is a bool");
            return (bool)v;
        }

        static TrackerSource Source(object v, string what)
        {
            if (v is string) return new TrackerSource { Bridge = (string)v };
            return new TrackerSource { ClientId = AsInt(v, what, 1) };
        }

        static Health ParseHealth(Dictionary<string, object> m)
        {
            var h = new Health { Status = OneOf(m, "health", "status", "ok", "degraded", "starting") };
            foreach (var e in List(m, "health", "reasons"))
            {
                var r = e as Dictionary<string, object>;
                if (r == null) throw Bad("health.reasons[n] is a map");
                h.Reasons.Add(new HealthReason { Code = Str(r, "health.reasons[n]", "code"), Message = Str(r, "health.reasons[n]", "message") });
            }
            return h;
        }

        static Lease ParseLease(Dictionary<string, object> m)
        {
            var lease = new Lease { Session = OptStr(m, "lease", "session"), TtlS = Positive(m, "lease", "ttl_s") };
            var holder = Field(m, "holder");
            if (holder != null)
            {
                var h = holder as Dictionary<string, object>;
                if (h == null) throw Bad("lease.holder is a map or null");
                lease.Holder = Party(h);
            }
            foreach (var e in List(m, "lease", "queue"))
            {
                var q = e as Dictionary<string, object>;
                if (q == null) throw Bad("lease.queue[n] is a map");
                lease.Queue.Add(Party(q));
            }
            return lease;
        }

        static Ask ParseAsk(Dictionary<string, object> m)
        {
            var ask = new Ask { Session = Str(m, "ask", "session"), Task = OptStr(m, "ask", "task"),
                                Instructions = Str(m, "ask", "instructions") };
            if (Field(m, "seq") != null) ask.Seq = Int(m, "ask", "seq", 0);
            foreach (var e in List(m, "ask", "questions"))
            {
                var q = e as Dictionary<string, object>;
                if (q == null) throw Bad("ask.questions[n] is a map");
                ask.Questions.Add(q);
            }
            var audio = Map(m, "ask", "audio", true);
            foreach (var kv in audio) Bool(kv.Value, "ask.audio." + kv.Key);
            ask.Speech = audio.ContainsKey("speech") && (bool)audio["speech"];
            ask.ContactSounds = audio.ContainsKey("contact_sounds") && (bool)audio["contact_sounds"];
            if (Field(m, "pacing") != null) ask.Pacing = Map(m, "ask", "pacing", true);  // v1.6
            return ask;
        }

        static LeaseParty Party(Dictionary<string, object> h)
        {
            return new LeaseParty
            {
                TokenId = OptStr(h, "lease", "token_id"), Role = OptStr(h, "lease", "role"), Site = OptStr(h, "lease", "site"),
                Label = OptStr(h, "lease", "label"),
                Position = Field(h, "position") == null ? 0 : AsInt(h["position"], "lease.queue[n].position", 1),
                Since = Field(h, "since") == null ? 0 : AsNum(h["since"], "lease.holder.since"),
                ExpiresAt = Field(h, "expires_at") == null ? 0 : AsNum(h["expires_at"], "lease.holder.expires_at"),
            };
        }

        // ---- field checks ---------------------------------------------------------------

        internal static ProtocolException Bad(string why) { return new ProtocolException("bad_message", why); }

        internal static object Field(Dictionary<string, object> m, string key)
        {
            object v;
            return m.TryGetValue(key, out v) ? v : null;
        }

        static string Str(Dictionary<string, object> m, string at, string key)
        {
            var s = Field(m, key) as string;
            if (s == null) throw Bad(at + "." + key + " is a string");
            return s;
        }

        static string OptStr(Dictionary<string, object> m, string at, string key)
        {
            var v = Field(m, key);
            if (v != null && !(v is string)) throw Bad(at + "." + key + " is a string or null");
            return (string)v;
        }

        static string OneOf(Dictionary<string, object> m, string at, string key, params string[] allowed)
        {
            var s = Str(m, at, key);
            if (Array.IndexOf(allowed, s) < 0) throw Bad(at + "." + key + " is one of " + string.Join(", ", allowed));
            return s;
        }

        internal static double AsNum(object v, string what)
        {
            if (v is long) return (long)v;
            if (v is double) return (double)v;
            throw Bad(what + " is a number");
        }

        /// <summary>An int field: an integral number (a float with an integral value too) within ±(2^53 − 1), at least `min`.</summary>
        internal static long AsInt(object v, string what, long min)
        {
            double d = AsNum(v, what);
            if (Math.Floor(d) != d) throw Bad(what + " is an integer");
            if (Math.Abs(d) > MaxSafeInteger) throw new ProtocolException("out_of_range", what + " is beyond ±(2^53 − 1)");
            long l = v is long ? (long)v : (long)d;
            if (l < min) throw Bad(what + " is at least " + min);
            return l;
        }

        static double Num(Dictionary<string, object> m, string at, string key) { return AsNum(Field(m, key), at + "." + key); }
        static long Int(Dictionary<string, object> m, string at, string key, long min) { return AsInt(Field(m, key), at + "." + key, min); }

        static double Positive(Dictionary<string, object> m, string at, string key)
        {
            double d = Num(m, at, key);
            if (!(d > 0)) throw Bad(at + "." + key + " is > 0");
            return d;
        }

        static bool Bool(object v, string what)
        {
            if (!(v is bool)) throw Bad(what + " values are bools");
            return (bool)v;
        }

        internal static Vec3 Vec(object v, string what)
        {
            var a = v as List<object>;
            if (a == null || a.Count != 3) throw Bad(what + " is [x, y, z]");
            return new Vec3(AsNum(a[0], what), AsNum(a[1], what), AsNum(a[2], what));
        }

        /// <summary>A quaternion [w, x, y, z] with a norm in [0.5, 2] (as the server checks tracker.quat), divided by its norm.</summary>
        internal static Quat UnitQuat(object v, string what)
        {
            var a = v as List<object>;
            if (a == null || a.Count != 4) throw Bad(what + " is [w, x, y, z]");
            var q = new Quat(AsNum(a[0], what), AsNum(a[1], what), AsNum(a[2], what), AsNum(a[3], what));
            double n = q.Norm;
            if (!(n >= 0.5 && n <= 2)) throw Bad(what + " has a norm in [0.5, 2]");
            return new Quat(q.W / n, q.X / n, q.Y / n, q.Z / n);
        }

        static List<object> List(Dictionary<string, object> m, string at, string key)
        {
            var l = Field(m, key) as List<object>;
            if (l == null) throw Bad(at + "." + key + " is an array");
            return l;
        }

        static readonly List<object> NoItems = new List<object>();
        static readonly Dictionary<string, object> NoEntries = new Dictionary<string, object>();

        static List<object> OptList(Dictionary<string, object> m, string at, string key)
        {
            var v = Field(m, key);
            if (v == null) return NoItems;
            var l = v as List<object>;
            if (l == null) throw Bad(at + "." + key + " is an array");
            return l;
        }

        static Dictionary<string, object> Map(Dictionary<string, object> m, string at, string key, bool required)
        {
            var v = Field(m, key);
            if (v == null && !required) return NoEntries;
            var d = v as Dictionary<string, object>;
            if (d == null) throw Bad(at + "." + key + " is a map");
            return d;
        }

        static double TelNum(Dictionary<string, object> tel, string key)
        {
            var v = Field(tel, key);
            return v is long ? (long)v : v is double ? (double)v : 0;
        }
    }
}
