// Every shared protocol vector (tests/vectors/messages.json, invalid.json): byte-exact encoding,
// decoding to the same map, and the client's refusals with their codes.
using System;
using System.Collections.Generic;
using System.Linq;
using NUnit.Framework;

namespace Viestac.Client.Tests
{
    [TestFixture]
    public class VectorTests
    {
        static Dictionary<string, object> Messages { get { return (Dictionary<string, object>)TestPaths.LoadVectors("messages.json"); } }
        static Dictionary<string, object> Invalid { get { return (Dictionary<string, object>)TestPaths.LoadVectors("invalid.json"); } }

        static IEnumerable<Dictionary<string, object>> Vectors(string file, string section)
        {
            var root = file == "messages.json" ? Messages : Invalid;
            return ((List<object>)root[section]).Cast<Dictionary<string, object>>();
        }

        [Test]
        public void EveryVectorMapEncodesToItsExactBytes()
        {
            var w = new MsgPackWriter();
            int n = 0;
            foreach (var v in Vectors("messages.json", "vectors"))
            {
                w.Clear();
                w.WriteValue(v["message"]);
                Assert.AreEqual((string)v["msgpack_hex"], TestPaths.ToHex(w.ToArray()), (string)v["name"]);
                n++;
            }
            Assert.That(n, Is.GreaterThanOrEqualTo(30));
        }

        [Test]
        public void APacedAskCarriesItsPacingAndAnOlderAskNone()
        {
            var r = new MsgPackReader();
            Func<string, Ask> ask = name => (Ask)Protocol.Parse(r.ReadFrame(TestPaths.Hex((string)Vectors("messages.json", "vectors")
                .First(v => (string)v["name"] == name)["msgpack_hex"])));
            var paced = ask("ask-paced-break");
            Assert.AreEqual("break", paced.Pacing["state"]);
            Assert.AreEqual(20L, Convert.ToInt64(paced.Pacing["done"]));
            Assert.IsNull(ask("ask-likert-audio").Pacing);  // v1.5: no pacing field
        }

        [Test]
        public void EveryVectorDecodesToItsMapWithIntsAndFloatsApart()
        {
            var r = new MsgPackReader();
            foreach (var v in Vectors("messages.json", "vectors"))
            {
                var decoded = r.ReadFrame(TestPaths.Hex((string)v["msgpack_hex"]));
                AssertSame(v["message"], decoded, (string)v["name"]);
            }
        }

        [Test]
        public void EveryServerVectorParsesAsItsType()
        {
            var r = new MsgPackReader();
            foreach (var v in Vectors("messages.json", "vectors").Where(v => (string)v["direction"] == "server_to_client"))
            {
                var message = Protocol.Parse(r.ReadFrame(TestPaths.Hex((string)v["msgpack_hex"])));
                Assert.IsNotNull(message, (string)v["name"]);
                Assert.AreEqual((string)v["type"], message.Type.ToString().ToLowerInvariant(), (string)v["name"]);
            }
        }

        [Test]
        public void TypedClientMessagesWriteTheVectorBytes()
        {
            var w = new MsgPackWriter();
            int n = 0;
            foreach (var v in Vectors("messages.json", "vectors").Where(v => (string)v["direction"] == "client_to_server"))
            {
                var m = (Dictionary<string, object>)v["message"];
                w.Clear();
                switch ((string)m["type"])
                {
                    case "hello":
                        Protocol.WriteHello(w, (string)m["role"], (string)m["client"], m.ContainsKey("token") ? (string)m["token"] : null);
                        break;
                    case "tracker":
                        Quat? q = null;
                        if (m.ContainsKey("quat")) { var a = Nums(m["quat"]); q = new Quat(a[0], a[1], a[2], a[3]); }
                        var p = Nums(m["pos"]);
                        var sample = new Tracker { Seq = Convert.ToInt64(m["seq"]), TMs = Convert.ToDouble(m["t"]), Pos = new Vec3(p[0], p[1], p[2]), Quat = q };
                        if (m.ContainsKey("point")) sample.Point = (string)m["point"];
                        if (m.ContainsKey("points"))
                            sample.Points = ((Dictionary<string, object>)m["points"]).Select(kv => { var a = Nums(kv.Value); return new PointPos(kv.Key, new Vec3(a[0], a[1], a[2])); }).ToList();
                        if (m.ContainsKey("ttl")) sample.TtlMs = Convert.ToDouble(m["ttl"]);
                        ClientChecks.CheckTracker(sample);
                        if (sample.Point == null && sample.Points == null && sample.TtlMs == null)
                            Protocol.WriteTracker(w, sample.Seq, sample.TMs, sample.Pos, q); // the v1.3 overload stays byte-exact
                        else Protocol.WriteTracker(w, sample);
                        break;
                    case "input":
                        Protocol.WriteInput(w, (string)m["key"], (string)m["action"], m.ContainsKey("value") ? m["value"] : null);
                        break;
                    case "answer":
                        Protocol.WriteAnswer(w, Convert.ToInt64(m["seq"]), (string)m["question"], m["value"]);
                        break;
                    case "actuators":
                        var list = ((List<object>)m["actuators"]).Select(a => ((List<object>)a).Cast<string>().ToArray()).ToList();
                        ClientChecks.CheckActuators((List<object>)m["actuators"], m.ContainsKey("note") ? m["note"] : null);
                        Protocol.WriteActuators(w, list, m.ContainsKey("note") ? (string)m["note"] : null);
                        break;
                    default: Assert.Fail("a client message of type " + m["type"]); break;
                }
                Assert.AreEqual((string)v["msgpack_hex"], TestPaths.ToHex(w.ToArray()), (string)v["name"]);
                n++;
            }
            Assert.That(n, Is.GreaterThanOrEqualTo(15));
        }

        [Test]
        public void TheBrowserActuatorOfAStateIsReadOnBothPaths()
        {
            var v = Vectors("messages.json", "vectors").First(x => (string)x["name"] == "state-browser-actuator-pulse-train");
            var bytes = TestPaths.Hex((string)v["msgpack_hex"]);
            var tree = (StateFrame)Protocol.Parse(new MsgPackReader().ReadFrame(bytes));
            var streamed = new StateFrame();
            Protocol.Decode(new MsgPackReader(), bytes, 0, bytes.Length, streamed);
            foreach (var s in new[] { tree, streamed })
            {
                Assert.IsTrue(s.HasActuator);
                Assert.AreEqual(new[] { 0.6, 100, 200, 900, 5170 }, s.Actuator);
            }
            var plain = Vectors("messages.json", "vectors").First(x => (string)x["name"] == "state-in-contact");
            var p = TestPaths.Hex((string)plain["msgpack_hex"]);
            Protocol.Decode(new MsgPackReader(), p, 0, p.Length, streamed);
            Assert.IsFalse(streamed.HasActuator, "a rig without a browser device sends none");
        }

        [Test]
        public void StateVectorFieldsReachTheTypedFrame()
        {
            var v = Vectors("messages.json", "vectors").First(x => (string)x["name"] == "state-in-contact");
            var m = (Dictionary<string, object>)v["message"];
            var s = (StateFrame)Protocol.Parse(new MsgPackReader().ReadFrame(TestPaths.Hex((string)v["msgpack_hex"])));
            Assert.AreEqual(Convert.ToInt64(m["frame"]), s.Frame);
            Assert.AreEqual(Convert.ToDouble(m["t"]), s.T);
            var hip = Nums(m["hip"]);
            Assert.AreEqual(hip[2], s.Hip.Z);
            Assert.AreEqual(((List<object>)m["contacts"]).Count, s.Contacts.Count);
            Assert.AreEqual(((List<object>)m["cues"]).Count, s.Cues.Count);
            var cue = (Dictionary<string, object>)((List<object>)m["cues"])[0];
            Assert.AreEqual((string)cue["kind"], s.Cues[0].Kind);
            Assert.IsTrue(s.Contact);
        }

        [Test]
        public void ReceivedServerFramesAreUnderstoodAsExpected()
        {
            var r = new MsgPackReader();
            int n = 0;
            foreach (var v in Vectors("messages.json", "received").Where(v => (string)v["direction"] == "server_to_client"))
            {
                var decoded = r.ReadFrame(TestPaths.Hex((string)v["msgpack_hex"]));
                Assert.IsNotNull(Protocol.Parse(decoded), (string)v["name"]);
                foreach (var kv in (Dictionary<string, object>)v["expect"])
                    AssertClose(kv.Value, ((Dictionary<string, object>)decoded)[kv.Key], v["name"] + "." + kv.Key);
                n++;
            }
            Assert.That(n, Is.GreaterThanOrEqualTo(3));
        }

        [Test]
        public void ReceivedClientFramesDecode()
        {
            // What a server must accept (integral floats, unnormalised quaternions) the reader reads.
            var r = new MsgPackReader();
            foreach (var v in Vectors("messages.json", "received").Where(v => (string)v["direction"] == "client_to_server"))
            {
                var decoded = (Dictionary<string, object>)r.ReadFrame(TestPaths.Hex((string)v["msgpack_hex"]));
                Assert.AreEqual(((Dictionary<string, object>)v["expect"])["type"], decoded["type"], (string)v["name"]);
            }
        }

        [Test]
        public void EveryRefusedServerFrameGetsItsCode()
        {
            var r = new MsgPackReader();
            int n = 0;
            foreach (var v in Vectors("invalid.json", "server_frames"))
            {
                var code = Refusal(r, (string)v["msgpack_hex"]);
                Assert.AreEqual((string)v["code"], code, (string)v["name"]);
                n++;
            }
            Assert.That(n, Is.GreaterThanOrEqualTo(30));
        }

        [Test]
        public void ClientFramesTheServerRefusesForEncodingAreRefusedByTheReaderToo()
        {
            // bad_encoding and non_finite are properties of the bytes: the reader says the same.
            var r = new MsgPackReader();
            int n = 0;
            foreach (var v in Vectors("invalid.json", "frames"))
            {
                var code = (string)v["code"];
                if (code != "bad_encoding" && code != "non_finite") continue;
                string got = null;
                try { r.ReadFrame(TestPaths.Hex((string)v["msgpack_hex"])); }
                catch (ProtocolException e) { got = e.Code; }
                Assert.AreEqual(code, got, (string)v["name"]);
                n++;
            }
            Assert.That(n, Is.GreaterThanOrEqualTo(2));
        }

        /// <summary>The session's path: Protocol.Decode (states read straight into a pooled frame).</summary>
        [Test]
        public void EveryFrameTheServerRefusesTheClientsChecksRefuseWithTheSameCode()
        {
            var r = new MsgPackReader();
            int n = 0;
            foreach (var v in Vectors("invalid.json", "frames"))
            {
                string got = "(accepted)";
                try { ClientChecks.Check(r.ReadFrame(TestPaths.Hex((string)v["msgpack_hex"]))); }
                catch (ProtocolException e) { got = e.Code; }
                Assert.AreEqual((string)v["code"], got, (string)v["name"]);
                n++;
            }
            Assert.That(n, Is.GreaterThanOrEqualTo(40));
            foreach (var v in Vectors("messages.json", "vectors").Concat(Vectors("messages.json", "received"))
                         .Where(x => (string)x["direction"] == "client_to_server"))
                Assert.DoesNotThrow(() => ClientChecks.Check(r.ReadFrame(TestPaths.Hex((string)v["msgpack_hex"]))), (string)v["name"]);
        }

        static string Refusal(MsgPackReader r, string hex)
        {
            var bytes = TestPaths.Hex(hex);
            try { Protocol.Decode(r, bytes, 0, bytes.Length, new StateFrame()); }
            catch (ProtocolException e) { return e.Code; }
            return "(accepted)";
        }

        [Test]
        public void EveryRefusedServerFrameGetsItsCodeFromTheTreePathToo()
        {
            var r = new MsgPackReader();
            foreach (var v in Vectors("invalid.json", "server_frames"))
            {
                string code = "(accepted)";
                try { Protocol.Parse(r.ReadFrame(TestPaths.Hex((string)v["msgpack_hex"]))); }
                catch (ProtocolException e) { code = e.Code; }
                Assert.AreEqual((string)v["code"], code, (string)v["name"]);
            }
        }

        [Test]
        public void TheDirectStateReaderAgreesWithTheTreePath()
        {
            var r = new MsgPackReader();
            var frames = Vectors("messages.json", "vectors").Concat(Vectors("messages.json", "received"))
                .Where(v => (string)v["type"] == "state").Select(v => TestPaths.Hex((string)v["msgpack_hex"])).ToList();
            Assert.That(frames.Count, Is.GreaterThanOrEqualTo(4));
            var direct = new StateFrame();
            foreach (var bytes in frames)
            {
                var viaTree = (StateFrame)Protocol.Parse(r.ReadFrame(bytes));
                Assert.AreSame(direct, Protocol.Decode(r, bytes, 0, bytes.Length, direct));
                Assert.AreEqual(Json.Write(Describe(viaTree)), Json.Write(Describe(direct)));
            }
        }

        static Dictionary<string, object> Describe(StateFrame s)
        {
            return new Dictionary<string, object>
            {
                { "frame", s.Frame }, { "tick", s.Tick }, { "t", s.T }, { "scene", s.SceneHash }, { "hud", s.Hud }, { "contact", s.Contact },
                { "hip", new List<object> { s.Hip.X, s.Hip.Y, s.Hip.Z } }, { "proxy", new List<object> { s.Proxy.X, s.Proxy.Y, s.Proxy.Z } },
                { "force", new List<object> { s.Force.X, s.Force.Y, s.Force.Z } },
                { "contacts", s.Contacts.Select(c => (object)new List<object> { c.ObjectId, c.Normal.X, c.Normal.Y, c.Normal.Z, c.Depth }).ToList() },
                { "objects", s.Objects.Select(o => (object)new List<object> { o.Id, o.Pos.X, o.Pos.Y, o.Pos.Z, o.Rot.W, o.Rot.X, o.Rot.Y, o.Rot.Z }).ToList() },
                { "cues", s.Cues.Select(c => (object)new List<object> { c.Kind, Json.Write(c.Fields.OrderBy(kv => kv.Key).Select(kv => (object)new List<object> { kv.Key, kv.Value }).ToList()) }).ToList() },
                { "values", s.Values.ToDictionary(kv => kv.Key, kv => kv.Value) },
                { "telemetry", new List<object> { s.Telemetry.PeriodP50Us, s.Telemetry.PeriodP99Us, s.Telemetry.PeriodMaxUs, s.Telemetry.TickCostP99Us, s.Telemetry.Overruns, s.Telemetry.Ticks, s.Telemetry.Rt } },
                { "visible", s.Visible.ToDictionary(kv => kv.Key, kv => (object)kv.Value) },
                { "haptic", s.Haptic.ToDictionary(kv => kv.Key, kv => (object)kv.Value) },
                { "stiffness", s.Stiffness.ToDictionary(kv => kv.Key, kv => (object)kv.Value) },
                { "scales", s.Scales.ToDictionary(kv => kv.Key, kv => (object)new List<object> { kv.Value.X, kv.Value.Y, kv.Value.Z }) },
                { "events", s.Events.Cast<object>().ToList() },
                { "driver", new List<object> { s.HasDriver, s.DriverClientId, s.DriverBridge, s.DriverSeq } },
                { "tools", s.Tools.Select(t => (object)new List<object> { t.Name, t.Hip.X, t.Hip.Y, t.Hip.Z, t.Proxy.X, t.Proxy.Y, t.Proxy.Z, t.Contact, t.Lost }).ToList() },
                { "points", s.Points.ToDictionary(kv => kv.Key, kv => (object)new List<object> { kv.Value.X, kv.Value.Y, kv.Value.Z }) },
                { "tracking", s.TrackingLost.Select(x => (object)new List<object> { x.ClientId, x.Bridge }).ToList() },
            };
        }

        [Test]
        public void DecodingStatesInSteadyStateLeavesNoGarbage()
        {
            // A frame with every field (values included) decoded many times into the same pooled
            // frame: were it to allocate even a few bytes a frame, the nursery would fill and collect.
            var v = Vectors("messages.json", "vectors").First(x => (string)x["name"] == "state-free-moving-objects");
            var bytes = TestPaths.Hex((string)v["msgpack_hex"]);
            var r = new MsgPackReader();
            var s = new StateFrame();
            for (int i = 0; i < 1000; i++) Protocol.Decode(r, bytes, 0, bytes.Length, s);
            int before = GC.CollectionCount(0);
            for (int i = 0; i < 300000; i++) Protocol.Decode(r, bytes, 0, bytes.Length, s);
            Assert.AreEqual(before, GC.CollectionCount(0), "collections while decoding");
            Assert.That(s.Objects.Count, Is.GreaterThan(0));
        }

        [Test]
        public void DecodingStatesWithToolsAndPointsLeavesNoGarbage()
        {
            // v1.4: two tools, a hand's points and a lost source, read into the pooled frame's lists
            // (events left out: they are the one part that allocates, as the README says)
            var m = new Dictionary<string, object>((Dictionary<string, object>)Vectors("messages.json", "vectors")
                .First(x => (string)x["name"] == "state-two-tools-hand-lost-source")["message"]);
            m.Remove("events");
            var w = new MsgPackWriter();
            w.WriteValue(m);
            var bytes = w.ToArray();
            var r = new MsgPackReader();
            var s = new StateFrame();
            for (int i = 0; i < 1000; i++) Protocol.Decode(r, bytes, 0, bytes.Length, s);
            int before = GC.CollectionCount(0);
            for (int i = 0; i < 300000; i++) Protocol.Decode(r, bytes, 0, bytes.Length, s);
            Assert.AreEqual(before, GC.CollectionCount(0), "collections while decoding");
            Assert.AreEqual(2, s.Tools.Count);
            Assert.AreEqual(2, s.Points.Count);
            Assert.AreEqual(1, s.TrackingLost.Count);
        }

        [Test]
        public void V14StateFieldsReachTheTypedFrame()
        {
            var v = Vectors("messages.json", "vectors").First(x => (string)x["name"] == "state-two-tools-hand-lost-source");
            var m = (Dictionary<string, object>)v["message"];
            var bytes = TestPaths.Hex((string)v["msgpack_hex"]);
            var s = (StateFrame)Protocol.Decode(new MsgPackReader(), bytes, 0, bytes.Length, new StateFrame());
            var tools = ((List<object>)m["tools"]).Cast<Dictionary<string, object>>().ToList();
            Assert.AreEqual(tools.Count, s.Tools.Count);
            for (int i = 0; i < tools.Count; i++)
            {
                Assert.AreEqual(tools[i]["name"], s.Tools[i].Name);
                Assert.AreEqual(Nums(tools[i]["hip"])[2], s.Tools[i].Hip.Z);
                Assert.AreEqual(Nums(tools[i]["proxy"])[0], s.Tools[i].Proxy.X);
                Assert.AreEqual(tools[i]["contact"], s.Tools[i].Contact);
                Assert.AreEqual(tools[i]["lost"], s.Tools[i].Lost);
            }
            Assert.AreEqual(TrackedPoints.Primary, s.Tools[0].Name, "the primary tool first");
            var points = (Dictionary<string, object>)m["points"];
            CollectionAssert.AreEquivalent(points.Keys, s.Points.Keys);
            foreach (var kv in points) Assert.AreEqual(Nums(kv.Value)[1], s.Points[kv.Key].Y, kv.Key);
            var lost = (List<object>)((Dictionary<string, object>)m["tracking"])["lost"];
            CollectionAssert.AreEqual(lost.Select(x => x.ToString()).ToList(), s.TrackingLost.Select(x => x.ToString()).ToList());
            var copy = new StateFrame();
            s.CopyTo(copy);
            Assert.AreEqual(Json.Write(Describe(s)), Json.Write(Describe(copy)));
        }

        [Test]
        public void TrackedPointNamesAreTheServersSet()
        {
            // server/core/points.py: 2 hands × (wrist, palm, 4 thumb joints, 4 fingers × 5 joints)
            Assert.AreEqual(2 * (2 + 4 + 4 * 5), TrackedPoints.All.Count);
            Assert.IsTrue(TrackedPoints.IsPointName("left.thumb.metacarpal"));
            Assert.IsFalse(TrackedPoints.IsPointName("left.thumb.intermediate"));
            Assert.IsFalse(TrackedPoints.IsPointName("right.index.nail"));
            Assert.AreEqual("right.index.distal", TrackedPoints.FromWebXR("right", "index-finger-phalanx-distal"));
        }

        static double[] Nums(object list) { return ((List<object>)list).Select(Convert.ToDouble).ToArray(); }

        /// <summary>Same value and same kind of number (an int stays an int, a float a float).</summary>
        internal static void AssertSame(object expected, object actual, string at)
        {
            if (expected is Dictionary<string, object>)
            {
                var e = (Dictionary<string, object>)expected;
                var a = actual as Dictionary<string, object>;
                Assert.IsNotNull(a, at + ": a map");
                CollectionAssert.AreEqual(e.Keys.ToList(), a.Keys.ToList(), at + ": keys in order");
                foreach (var kv in e) AssertSame(kv.Value, a[kv.Key], at + "." + kv.Key);
            }
            else if (expected is List<object>)
            {
                var e = (List<object>)expected;
                var a = actual as List<object>;
                Assert.IsNotNull(a, at + ": an array");
                Assert.AreEqual(e.Count, a.Count, at + ": length");
                for (int i = 0; i < e.Count; i++) AssertSame(e[i], a[i], at + "[" + i + "]");
            }
            else
            {
                Assert.AreEqual(expected == null ? null : expected.GetType(), actual == null ? null : actual.GetType(), at + ": type");
                Assert.AreEqual(expected, actual, at);
            }
        }

        static void AssertClose(object expected, object actual, string at)
        {
            if (expected is long || expected is double)
            {
                Assert.That(actual is long || actual is double, at + " is a number");
                Assert.AreEqual(Convert.ToDouble(expected), Convert.ToDouble(actual), 1e-12, at);
            }
            else if (expected is List<object>)
            {
                var e = (List<object>)expected; var a = (List<object>)actual;
                Assert.AreEqual(e.Count, a.Count, at);
                for (int i = 0; i < e.Count; i++) AssertClose(e[i], a[i], at + "[" + i + "]");
            }
            else if (expected is Dictionary<string, object>)
            {
                foreach (var kv in (Dictionary<string, object>)expected) AssertClose(kv.Value, ((Dictionary<string, object>)actual)[kv.Key], at + "." + kv.Key);
            }
            else Assert.AreEqual(expected, actual, at);
        }
    }
}
