// tests/vectors/scene_hash.json: canonical JSON text and hash of every case, the canonical spelling
// of every number; and the hash of every scene vector in messages.json.
using System;
using System.Collections.Generic;
using System.Linq;
using NUnit.Framework;

namespace Viestac.Client.Tests
{
    [TestFixture]
    public class SceneHashTests
    {
        static Dictionary<string, object> File { get { return (Dictionary<string, object>)TestPaths.LoadVectors("scene_hash.json"); } }

        [Test]
        public void EveryCaseHasItsCanonicalTextAndHash()
        {
            var cases = ((List<object>)File["cases"]).Cast<Dictionary<string, object>>().ToList();
            Assert.That(cases.Count, Is.GreaterThanOrEqualTo(4));
            foreach (var c in cases)
            {
                Assert.AreEqual((string)c["canonical"], SceneHash.CanonicalJson(c["value"]), (string)c["name"]);
                Assert.AreEqual((string)c["hash"], SceneHash.Of((Dictionary<string, object>)c["value"]), (string)c["name"]);
            }
        }

        [Test]
        public void EveryNumberIsSpelledAsECMAScriptDoes()
        {
            var numbers = ((List<object>)File["numbers"]).Cast<Dictionary<string, object>>().ToList();
            Assert.That(numbers.Count, Is.GreaterThanOrEqualTo(20));
            foreach (var n in numbers)
            {
                double v = BitConverter.Int64BitsToDouble(Convert.ToInt64((string)n["bits"], 16));
                // the canonical-number rule first: integral below 2^53 is an integer
                object canonical = Math.Floor(v) == v && Math.Abs(v) < 9007199254740992.0 ? (object)(long)v : v;
                Assert.AreEqual((string)n["canonical"], SceneHash.CanonicalJson(canonical), (string)n["bits"]);
            }
        }

        [Test]
        public void EverySceneVectorCarriesTheHashOfItsMap()
        {
            var root = (Dictionary<string, object>)TestPaths.LoadVectors("messages.json");
            var r = new MsgPackReader();
            int n = 0;
            foreach (var v in ((List<object>)root["vectors"]).Cast<Dictionary<string, object>>().Where(x => (string)x["type"] == "scene"))
            {
                var scene = (SceneMessage)Protocol.Parse(r.ReadFrame(TestPaths.Hex((string)v["msgpack_hex"])));
                Assert.AreEqual(scene.Hash, SceneHash.Of(scene.Raw), (string)v["name"]);
                Assert.IsTrue(scene.HashVerified, (string)v["name"]);
                var tampered = (Dictionary<string, object>)r.ReadFrame(TestPaths.Hex((string)v["msgpack_hex"]));
                ((Dictionary<string, object>)tampered["scene"])["name"] = "other";
                Assert.IsFalse(((SceneMessage)Protocol.Parse(tampered)).HashVerified, (string)v["name"] + " changed");
                n++;
            }
            Assert.That(n, Is.GreaterThanOrEqualTo(3));
        }
    }
}
