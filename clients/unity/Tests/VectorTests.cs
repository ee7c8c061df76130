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
                        Protocol.WriteTracker(w, Convert.ToInt64(m["seq"]), Convert.ToDouble(m["t"]), new Vec3(p[0], p[1], p[2]), q);
                        break;
                    case "input":
                        Protocol.WriteInput(w, (string)m["key"], (string)m["action"], m.ContainsKey("value") ? m["value"] : null);
                        break;
                    default: Assert.Fail("a client message of type " + m["type"]); break;
                }
                Assert.AreEqual((string)v["msgpack_hex"], TestPaths.ToHex(w.ToArray()), (string)v["name"]);
                n++;
            }
            Assert.That(n, Is.GreaterThanOrEqualTo(15));
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

        static string Refusal(MsgPackReader r, string hex)
        {
            try { Protocol.Parse(r.ReadFrame(TestPaths.Hex(hex))); }
            catch (ProtocolException e) { return e.Code; }
            return "(accepted)";
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
