// Against a real `viestac serve --port 0` started here (simulated rig): the welcome with the
// token's identity, a contact with the force and cue the physics give, a scenario switch, and
// reconnecting after the server restarts. Category "live" (build.sh --no-live skips them).
using System;
using System.Collections.Generic;
using System.Linq;
using System.Threading;
using NUnit.Framework;

namespace Viestac.Client.Tests
{
    [TestFixture, Category("live")]
    public class LiveTests
    {
        LiveServer _server;

        [TestFixtureSetUp] public void StartServer() { _server = new LiveServer(); _server.Start(); }
        [TestFixtureTearDown] public void StopServer() { if (_server != null) _server.Dispose(); }

        ViestacSession Connect(string role = Roles.Participant, string token = "")
        {
            var s = new ViestacSession(new SessionOptions
            {
                Url = _server.Ws, Token = token == "" ? _server.Token : token, Role = role, ClientName = "nunit",
                Backoff = new Backoff { InitialS = 0.2, MaxS = 1 }, Log = _ => { },
            });
            s.Start();
            return s;
        }

        /// <summary>Drains on this thread (the "main thread") until `done` or the timeout.</summary>
        static bool Pump(ViestacSession s, Func<bool> done, double seconds = 20)
        {
            var end = DateTime.UtcNow.AddSeconds(seconds);
            while (DateTime.UtcNow < end) { s.Drain(); if (done()) return true; Thread.Sleep(5); }
            return false;
        }

        [Test]
        public void A_WelcomeSceneAndStatesCarryTheTokensIdentity()
        {
            using (var s = Connect())
            {
                var states = new List<string>();
                s.StateReceived += st => states.Add(st.SceneHash);
                Assert.IsTrue(Pump(s, () => states.Count >= 10), "ten states");
                Assert.AreEqual("participant", s.Welcome.Role);
                Assert.That(s.Welcome.Minor, Is.GreaterThanOrEqualTo(3), "a v1.3 server or later");
                Assert.AreEqual("admin", s.Welcome.Identity.Role);
                Assert.IsNotNull(s.Scene.Scene.Objects.FirstOrDefault(o => o.Shape.Type == "hemisphere"));
                Assert.IsTrue(s.Scene.HashVerified, "the server's scene hashes to its hash here too");
                Assert.IsTrue(states.All(h => h == s.Scene.Hash), "every state names the scene received");
                Assert.AreEqual(0, s.ProtocolErrors);
            }
        }

        [Test]
        public void B_ATouchOfTheDomeGivesTheSpringForceAndTheTiltCue()
        {
            using (var s = Connect())
            {
                Assert.IsTrue(Pump(s, () => s.Scene != null && s.Welcome != null));
                var scene = s.Scene.Scene;
                var dome = scene.Objects.First(o => o.Shape.Type == "hemisphere");
                double reach = dome.Shape.Radius + scene.Hip.ProxyRadius, inset = 0.004, angle = 30 * Math.PI / 180;
                var hip = new Vec3(dome.Pos.X, dome.Pos.Y + (reach - inset) * Math.Sin(angle), dome.Pos.Z + (reach - inset) * Math.Cos(angle));
                StateFrame touched = new StateFrame();
                bool got = false;
                s.StateReceived += st =>
                {
                    object a;
                    if (got || !st.Contact || !st.DrivenBy(s.Welcome.ClientId) || !st.Values.TryGetValue("angle_deg", out a)) return;
                    if (Math.Abs(Convert.ToDouble(a) - 30) < 0.5 && st.Cues.Any(c => c.Kind == "tilt")) { st.CopyTo(touched); got = true; }
                };
                Assert.IsTrue(Pump(s, () => { s.SendTracker(hip); return got; }), "the HIP reached the dome at 30°");
                double k;
                if (!touched.Stiffness.TryGetValue(dome.Id, out k)) k = dome.Material.StiffnessNPerM;
                var contact = touched.Contacts.Single(c => c.ObjectId == dome.Id);
                Assert.AreEqual(Math.Sin(angle), contact.Normal.Y, 1e-3, "the outward normal at 30°");
                Assert.AreEqual(Math.Cos(angle), contact.Normal.Z, 1e-3);
                Assert.AreEqual(inset, contact.Depth, 2e-4);
                // one contact: force · n = k · depth, and the force points along n
                double along = touched.Force.X * contact.Normal.X + touched.Force.Y * contact.Normal.Y + touched.Force.Z * contact.Normal.Z;
                Assert.AreEqual(k * contact.Depth, along, 1e-3 * k * contact.Depth + 1e-5);
                Assert.AreEqual(k * inset * Math.Sin(angle), touched.Force.Y, 0.05 * k * inset);
                var tilt = touched.Cues.First(c => c.Kind == "tilt");
                Assert.AreEqual(330, tilt.Get("direction_deg"), 0.5, "a tilt toward −30° (0 = front, 90 = right)");
                Assert.That(tilt.Get("magnitude_pct"), Is.GreaterThan(0));
            }
        }

        [Test]
        public void B2_AHandInOneSampleReachesStatePointsAndItsLossIsReported()
        {
            using (var s = Connect())
            {
                Assert.IsTrue(Pump(s, () => s.Scene != null && s.Welcome != null));
                Assert.AreEqual(6, s.Welcome.Minor);  // v1.6 (was 5)
                var hand = new List<PointPos>
                {
                    new PointPos("right.wrist", new Vec3(0.1, 0.2, 1.9)), new PointPos("right.index.tip", new Vec3(0.1, 0.2, 1.6)),
                    new PointPos("right.palm", new Vec3(0.1, 0.2, 1.8)),
                };
                StateFrame seen = new StateFrame(), lost = new StateFrame();
                bool gotHand = false, gotLoss = false, sending = true;
                s.StateReceived += st =>
                {
                    if (!gotHand && st.DrivenBy(s.Welcome.ClientId) && st.Points.ContainsKey("right.wrist")) { st.CopyTo(seen); gotHand = true; }
                    if (gotHand && !sending && !gotLoss && st.TrackingLost.Any(x => x.Bridge == null && x.ClientId == s.Welcome.ClientId)) { st.CopyTo(lost); gotLoss = true; }
                };
                Assert.IsTrue(Pump(s, () => { s.SendTrackerPoints(hand, null, 300); return gotHand; }), "the hand reached state.points");
                Assert.AreEqual(TrackedPoints.Primary, seen.Tools[0].Name);
                Assert.AreEqual(1.6, seen.Tools[0].Hip.Z, 1e-9, "the HIP is the index tip of the sample");
                Assert.AreEqual(1.9, seen.Points["right.wrist"].Z, 1e-9);
                Assert.AreEqual(1.8, seen.Points["right.palm"].Z, 1e-9);
                sending = false;
                Assert.IsTrue(Pump(s, () => gotLoss), "300 ms without a sample: the source is lost");
                Assert.IsTrue(lost.Tools[0].Lost);
                Assert.IsFalse(lost.Points.ContainsKey("right.wrist"), "a lost source's points leave state.points");
            }
        }

        [Test]
        public void C_AScenarioSwitchSendsTheNewSceneAndStatesNameIt()
        {
            using (var s = Connect(Roles.Operator))
            using (var rest = new ViestacRest(_server.Http, _server.Token))
            {
                Assert.IsTrue(Pump(s, () => s.Scene != null));
                var before = s.Scene.Hash;
                string lastStateScene = null;
                s.StateReceived += st => lastStateScene = st.SceneHash;
                var answer = rest.SwitchScenario("texture-v1").Result;
                Assert.IsTrue(answer.Ok, "HTTP " + answer.Status + " " + Json.Write(answer.Body));
                try
                {
                    Assert.IsTrue(Pump(s, () => s.Scene.Hash != before && lastStateScene == s.Scene.Hash), "a new scene and states naming it");
                    Assert.AreNotEqual("contact-angle", s.Scene.Scene.Name);
                    Assert.IsTrue(s.Scene.HashVerified, "the new scene hashes to its hash");
                }
                finally
                {
                    Assert.IsTrue(rest.SwitchScenario("contact-angle-v1").Result.Ok);
                    Assert.IsTrue(Pump(s, () => s.Scene.Hash == before), "back to contact-angle");
                }
            }
        }

        [Test]
        public void D_WithoutATokenTheServerRefusesAndTheClientStops()
        {
            using (var s = Connect(Roles.Observer, null))
            {
                string code = null;
                s.ErrorReceived += e => code = e.Code;
                Assert.IsTrue(Pump(s, () => s.Status == ConnectionStatus.Refused));
                Assert.AreEqual("unauthorized", code);
                Thread.Sleep(500);
                Assert.AreEqual(1, s.Connections, "no reconnect after unauthorized");
            }
        }

        [Test]
        public void E_ReconnectsAfterTheServerRestarts()
        {
            using (var s = Connect())
            {
                var welcomes = new List<long>();
                long states = 0;
                s.Welcomed += w => welcomes.Add(w.ClientId);
                s.StateReceived += _ => states++;
                Assert.IsTrue(Pump(s, () => states > 5));
                int port = _server.Port;
                _server.Stop();
                Assert.IsTrue(Pump(s, () => s.Status == ConnectionStatus.Reconnecting), "the client noticed");
                _server.Start(port);
                states = 0;
                Assert.IsTrue(Pump(s, () => welcomes.Count == 2 && states > 5, 30), "welcomed again with states");
                Assert.That(s.Connections, Is.GreaterThanOrEqualTo(2));
                Assert.AreEqual(ConnectionStatus.Connected, s.Status);
            }
        }
    }
}
