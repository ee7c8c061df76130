// `state` frames (60 a second) read straight from the msgpack bytes into a pooled StateFrame: the
// same checks as Protocol.Parse's tree path (the vector tests hold both to the same answers),
// without a map or list per frame. Strings come from the reader's cache, numbers into fields.
using System;
using System.Collections.Generic;

namespace Viestac.Client
{
    static class StateReader
    {
        const string At = "state";
        // required fields, one bit each
        const int Frame = 1, Tick = 2, T = 4, Scene = 8, Hip = 16, Proxy = 32, Force = 64, ContactBit = 128,
                  Contacts = 256, Objects = 512, Cues = 1024, Hud = 2048, Values = 4096, Telemetry = 8192, All = 16383;
        static readonly string[] Names = { "frame", "tick", "t", "scene", "hip", "proxy", "force", "contact", "contacts",
                                           "objects", "cues", "hud", "values", "telemetry" };

        public static void Read(MsgPackReader r, StateFrame s)
        {
            s.Reset();
            int seen = 0;
            int n = r.ReadMapHeader("a message");
            for (int i = 0; i < n; i++)
            {
                if (!r.IsString) throw Protocol.Bad("a map key is not a string");
                var key = r.ReadString("a key");
                switch (key)
                {
                    case "type": r.ReadString("type"); break;
                    case "frame": s.Frame = Int(r, "state.frame", 0); seen |= Frame; break;
                    case "tick": s.Tick = Int(r, "state.tick", 0); seen |= Tick; break;
                    case "t": s.T = r.ReadNumber("state.t"); seen |= T; break;
                    case "scene": s.SceneHash = r.ReadString("state.scene"); seen |= Scene; break;
                    case "hip": s.Hip = Vec(r, "state.hip"); seen |= Hip; break;
                    case "proxy": s.Proxy = Vec(r, "state.proxy"); seen |= Proxy; break;
                    case "force": s.Force = Vec(r, "state.force"); seen |= Force; break;
                    case "contact": s.Contact = r.ReadBool("state.contact"); seen |= ContactBit; break;
                    case "contacts": ReadContacts(r, s); seen |= Contacts; break;
                    case "objects": ReadObjects(r, s); seen |= Objects; break;
                    case "cues": ReadCues(r, s); seen |= Cues; break;
                    case "hud": s.Hud = r.ReadString("state.hud"); seen |= Hud; break;
                    case "values": ReadValues(r, s); seen |= Values; break;
                    case "telemetry": s.Telemetry = ReadTelemetry(r); seen |= Telemetry; break;
                    case "visible": if (!r.TryReadNil()) ReadBools(r, s.Visible, "state.visible"); break;
                    case "haptic": if (!r.TryReadNil()) ReadBools(r, s.Haptic, "state.haptic"); break;
                    case "events": if (!r.TryReadNil()) ReadEvents(r, s); break;
                    case "scales":
                        if (r.TryReadNil()) break;
                        for (int k = r.ReadMapHeader("state.scales"); k > 0; k--) s.Scales[Key(r)] = Vec(r, "state.scales");
                        break;
                    case "stiffness":
                        if (r.TryReadNil()) break;
                        for (int k = r.ReadMapHeader("state.stiffness"); k > 0; k--)
                        {
                            var id = Key(r);
                            double v = r.ReadNumber("state.stiffness");
                            if (v < 0) throw Protocol.Bad("state.stiffness values are ≥ 0");
                            s.Stiffness[id] = v;
                        }
                        break;
                    case "driver": if (!r.TryReadNil()) ReadDriver(r, s); break;
                    case "tools": if (!r.TryReadNil()) ReadTools(r, s); break;
                    case "points":
                        if (r.TryReadNil()) break;
                        for (int k = r.ReadMapHeader("state.points"); k > 0; k--)
                        {
                            var name = Key(r);
                            if (!TrackedPoints.IsPointName(name)) throw Protocol.Bad("state.points keys are point names");
                            s.Points[name] = Vec(r, "state.points");
                        }
                        break;
                    case "tracking": if (!r.TryReadNil()) ReadTracking(r, s); break;
                    case "actuator":
                        if (r.TryReadNil()) break;
                        if (r.ReadArrayHeader("state.actuator") != 5) throw Protocol.Bad(Protocol.ActuatorShape);
                        for (int k = 0; k < 5; k++) s.Actuator[k] = r.ReadNumber("state.actuator");
                        Protocol.CheckActuator(s.Actuator);
                        s.HasActuator = true;
                        break;
                    default: r.Skip(1); break;
                }
            }
            if (seen != All)
                for (int b = 0; b < Names.Length; b++)
                    if ((seen & (1 << b)) == 0) throw Protocol.Bad("state." + Names[b] + " is missing");
        }

        static string Key(MsgPackReader r)
        {
            if (!r.IsString) throw Protocol.Bad("a map key is not a string");
            return r.ReadString("a key");
        }

        static long Int(MsgPackReader r, string what, long min)
        {
            double d = r.ReadNumber(what);
            if (Math.Floor(d) != d) throw Protocol.Bad(what + " is an integer");
            if (Math.Abs(d) > Protocol.MaxSafeInteger) throw new ProtocolException("out_of_range", what + " is beyond ±(2^53 − 1)");
            if (d < min) throw Protocol.Bad(what + " is at least " + min);
            return (long)d;
        }

        static Vec3 Vec(MsgPackReader r, string what)
        {
            if (r.ReadArrayHeader(what) != 3) throw Protocol.Bad(what + " is [x, y, z]");
            return new Vec3(r.ReadNumber(what), r.ReadNumber(what), r.ReadNumber(what));
        }

        static void ReadContacts(MsgPackReader r, StateFrame s)
        {
            for (int n = r.ReadArrayHeader("state.contacts"); n > 0; n--)
            {
                const string what = "state.contacts[n] is [object_id, [nx, ny, nz], depth]";
                if (r.ReadArrayHeader(what) != 3 || !r.IsString) throw Protocol.Bad(what);
                var c = new Contact { ObjectId = r.ReadString(what), Normal = Vec(r, "state.contacts[n][1]"), Depth = r.ReadNumber("state.contacts[n][2]") };
                if (c.Depth < 0) throw Protocol.Bad("state.contacts[n] depth is ≥ 0");
                s.Contacts.Add(c);
            }
        }

        static void ReadObjects(MsgPackReader r, StateFrame s)
        {
            for (int n = r.ReadArrayHeader("state.objects"); n > 0; n--)
            {
                const string what = "state.objects[n] is [object_id, [x, y, z], [w, x, y, z]]";
                if (r.ReadArrayHeader(what) != 3 || !r.IsString) throw Protocol.Bad(what);
                var o = new ObjectPose { Id = r.ReadString(what), Pos = Vec(r, "state.objects[n][1]") };
                if (r.ReadArrayHeader("state.objects[n][2]") != 4) throw Protocol.Bad("state.objects[n][2] is [w, x, y, z]");
                var q = new Quat(r.ReadNumber(what), r.ReadNumber(what), r.ReadNumber(what), r.ReadNumber(what));
                double norm = q.Norm;
                if (!(norm >= 0.5 && norm <= 2)) throw Protocol.Bad("state.objects[n][2] has a norm in [0.5, 2]");
                o.Rot = new Quat(q.W / norm, q.X / norm, q.Y / norm, q.Z / norm);
                s.Objects.Add(o);
            }
        }

        static void ReadCues(MsgPackReader r, StateFrame s)
        {
            for (int n = r.ReadArrayHeader("state.cues"); n > 0; n--)
            {
                if (!r.IsMap) throw Protocol.Bad("state.cues[n] is a map with a string `kind`");
                var cue = s.RentCue();
                cue.Kind = null;
                for (int k = r.ReadMapHeader("state.cues[n]"); k > 0; k--)
                {
                    var key = Key(r);
                    if (key == "kind")
                    {
                        if (!r.IsString) throw Protocol.Bad("state.cues[n] is a map with a string `kind`");
                        cue.Kind = r.ReadString("kind");
                    }
                    else if (r.IsNumber) cue.Fields[key] = r.ReadNumber(key);
                    else r.Skip(3);
                }
                s.Cues.Add(cue);
                if (cue.Kind == null) throw Protocol.Bad("state.cues[n] is a map with a string `kind`");
            }
        }

        static void ReadValues(MsgPackReader r, StateFrame s)
        {
            var boxes = s.ValueBoxes;
            if (boxes.Count > 256) boxes.Clear(); // keys that come and go: do not keep them all
            for (int n = r.ReadMapHeader("state.values"); n > 0; n--)
            {
                var key = Key(r);
                object previous;
                boxes.TryGetValue(key, out previous);
                var v = r.ReadValue(2, previous);
                boxes[key] = v;
                s.Values[key] = v;
            }
        }

        static Telemetry ReadTelemetry(MsgPackReader r)
        {
            var t = new Telemetry();
            for (int n = r.ReadMapHeader("state.telemetry"); n > 0; n--)
            {
                var key = Key(r);
                if (key == "rt" && r.IsBool) { t.Rt = r.ReadBool("state.telemetry.rt"); continue; }
                if (!r.IsNumber) { r.Skip(2); continue; }
                double v = r.ReadNumber(key);
                switch (key)
                {
                    case "period_p50_us": t.PeriodP50Us = v; break;
                    case "period_p99_us": t.PeriodP99Us = v; break;
                    case "period_max_us": t.PeriodMaxUs = v; break;
                    case "tick_cost_p99_us": t.TickCostP99Us = v; break;
                    case "overruns": t.Overruns = (long)v; break;
                    case "ticks": t.Ticks = (long)v; break;
                }
            }
            return t;
        }

        static void ReadBools(MsgPackReader r, Dictionary<string, bool> into, string what)
        {
            for (int n = r.ReadMapHeader(what); n > 0; n--) into[Key(r)] = r.ReadBool(what); // no concatenation here: it would allocate every frame
        }

        static void ReadEvents(MsgPackReader r, StateFrame s)
        {
            for (int n = r.ReadArrayHeader("state.events"); n > 0; n--)
            {
                var ev = r.ReadValue(2, null) as Dictionary<string, object>;
                if (ev == null) throw Protocol.Bad("state.events[n] is a map");
                s.Events.Add(ev);
            }
        }

        static void ReadTools(MsgPackReader r, StateFrame s)
        {
            const string what = "state.tools[n] is a map {name, hip, proxy, contact, lost}";
            for (int n = r.ReadArrayHeader("state.tools"); n > 0; n--)
            {
                if (!r.IsMap) throw Protocol.Bad(what);
                var tool = new ToolState();
                int seen = 0; // name, hip, proxy
                for (int k = r.ReadMapHeader(what); k > 0; k--)
                {
                    switch (Key(r))
                    {
                        case "name":
                            if (!r.IsString) throw Protocol.Bad("state.tools[n].name is a string");
                            tool.Name = r.ReadString("state.tools[n].name"); seen |= 1; break;
                        case "hip": tool.Hip = Vec(r, "state.tools[n].hip"); seen |= 2; break;
                        case "proxy": tool.Proxy = Vec(r, "state.tools[n].proxy"); seen |= 4; break;
                        case "contact": tool.Contact = !r.TryReadNil() && r.ReadBool("state.tools[n].contact"); break;
                        case "lost": tool.Lost = !r.TryReadNil() && r.ReadBool("state.tools[n].lost"); break;
                        default: r.Skip(3); break;
                    }
                }
                if ((seen & 1) == 0) throw Protocol.Bad("state.tools[n].name is a string");
                if ((seen & 2) == 0) throw Protocol.Bad("state.tools[n].hip is [x, y, z]");
                if ((seen & 4) == 0) throw Protocol.Bad("state.tools[n].proxy is [x, y, z]");
                s.Tools.Add(tool);
            }
        }

        static void ReadTracking(MsgPackReader r, StateFrame s)
        {
            for (int k = r.ReadMapHeader("state.tracking"); k > 0; k--)
            {
                if (Key(r) != "lost") { r.Skip(2); continue; }
                if (r.TryReadNil()) continue;
                for (int n = r.ReadArrayHeader("state.tracking.lost"); n > 0; n--)
                {
                    if (r.IsString) s.TrackingLost.Add(new TrackerSource { Bridge = r.ReadString("state.tracking.lost[n]") });
                    else s.TrackingLost.Add(new TrackerSource { ClientId = Int(r, "state.tracking.lost[n]", 1) });
                }
            }
        }

        static void ReadDriver(MsgPackReader r, StateFrame s)
        {
            if (r.ReadArrayHeader("state.driver") != 2) throw Protocol.Bad("state.driver is [client_id, seq] or null");
            s.HasDriver = true;
            if (r.IsString) s.DriverBridge = r.ReadString("state.driver[0]");
            else s.DriverClientId = Int(r, "state.driver[0]", 1);
            s.DriverSeq = Int(r, "state.driver[1]", 0);
        }
    }
}
