// Coordinates, interpolation, backoff and point names: pure parts, no server.
using System;
using System.Collections.Generic;
using System.Linq;
using NUnit.Framework;

namespace Viestac.Client.Tests
{
    [TestFixture]
    public class CoordinateTests
    {
        static double[] Nums(object list) { return ((List<object>)list).Select(Convert.ToDouble).ToArray(); }
        static List<Dictionary<string, object>> Section(string name)
        {
            var root = (Dictionary<string, object>)TestPaths.LoadVectors("coordinates.json");
            return ((List<object>)root[name]).Cast<Dictionary<string, object>>().ToList();
        }

        [Test]
        public void VectorPointsConvertToUnityAndBack()
        {
            var points = Section("points");
            Assert.That(points.Count, Is.GreaterThanOrEqualTo(5));
            foreach (var p in points)
            {
                var s = Nums(p["scene"]); var u = Nums(p["unity"]);
                float x, y, z;
                Coordinates.ToUnity(new Vec3(s[0], s[1], s[2]), out x, out y, out z);
                Assert.AreEqual(u[0], x, 1e-6); Assert.AreEqual(u[1], y, 1e-6); Assert.AreEqual(u[2], z, 1e-6);
                var back = Coordinates.FromUnity(u[0], u[1], u[2]);
                Assert.AreEqual(s[0], back.X, 1e-12); Assert.AreEqual(s[1], back.Y, 1e-12); Assert.AreEqual(s[2], back.Z, 1e-12);
            }
        }

        [Test]
        public void VectorRotationsConvertToUnityAndBack()
        {
            var rotations = Section("rotations");
            Assert.That(rotations.Count, Is.GreaterThanOrEqualTo(5));
            foreach (var r in rotations)
            {
                var s = Nums(r["scene"]); var u = Nums(r["unity_xyzw"]);
                float x, y, z, w;
                Coordinates.ToUnity(new Quat(s[0], s[1], s[2], s[3]), out x, out y, out z, out w);
                Assert.AreEqual(u[0], x, 1e-6); Assert.AreEqual(u[1], y, 1e-6); Assert.AreEqual(u[2], z, 1e-6); Assert.AreEqual(u[3], w, 1e-6);
                var back = Coordinates.FromUnity(u[0], u[1], u[2], u[3]);
                Assert.AreEqual(s[0], back.W, 1e-12); Assert.AreEqual(s[1], back.X, 1e-12);
                Assert.AreEqual(s[2], back.Y, 1e-12); Assert.AreEqual(s[3], back.Z, 1e-12);
            }
        }

        /// <summary>q·p·q* on the numbers: what Unity's `Quaternion * Vector3` computes from (x, y, z, w).</summary>
        static double[] Rotate(double w, double x, double y, double z, double[] p)
        {
            // t = 2 (q × p); p' = p + w t + q × t
            double tx = 2 * (y * p[2] - z * p[1]), ty = 2 * (z * p[0] - x * p[2]), tz = 2 * (x * p[1] - y * p[0]);
            return new[] { p[0] + w * tx + (y * tz - z * ty), p[1] + w * ty + (z * tx - x * tz), p[2] + w * tz + (x * ty - y * tx) };
        }

        [Test]
        public void RandomPosesRotateTheSameInBothFrames()
        {
            // Rotating a point in the scene frame and converting it equals converting both and
            // rotating with Unity's formula: the conversion is a proper change of frame.
            var rng = new Random(22);
            for (int i = 0; i < 1000; i++)
            {
                var q = new Quat(rng.NextDouble() * 2 - 1, rng.NextDouble() * 2 - 1, rng.NextDouble() * 2 - 1, rng.NextDouble() * 2 - 1);
                double n = q.Norm; q = new Quat(q.W / n, q.X / n, q.Y / n, q.Z / n);
                var p = new Vec3(rng.NextDouble() * 4 - 2, rng.NextDouble() * 4 - 2, rng.NextDouble() * 4 - 2);
                var sceneRotated = Rotate(q.W, q.X, q.Y, q.Z, new[] { p.X, p.Y, p.Z });
                var expected = Coordinates.ToUnity(new Vec3(sceneRotated[0], sceneRotated[1], sceneRotated[2]));
                float ux, uy, uz, uw;
                Coordinates.ToUnity(q, out ux, out uy, out uz, out uw);
                var up = Coordinates.ToUnity(p);
                var got = Rotate(uw, ux, uy, uz, new[] { up.X, up.Y, up.Z });
                Assert.AreEqual(expected.X, got[0], 1e-5, "pose " + i);
                Assert.AreEqual(expected.Y, got[1], 1e-5, "pose " + i);
                Assert.AreEqual(expected.Z, got[2], 1e-5, "pose " + i);
                var back = Coordinates.FromUnity(ux, uy, uz, uw);
                Assert.AreEqual(Math.Abs(q.W * back.W + q.X * back.X + q.Y * back.Y + q.Z * back.Z), 1.0, 1e-6, "round trip " + i);
            }
        }
    }

    [TestFixture]
    public class StateBufferTests
    {
        static StateFrame Frame(double t, double x, params ObjectPose[] objects)
        {
            var s = new StateFrame { T = t, Hip = new Vec3(x, 0, 0), Proxy = new Vec3(x, 0, 1) };
            s.Objects.AddRange(objects);
            return s;
        }

        [Test]
        public void InterpolatesBetweenFramesAtTheDelayedServerTime()
        {
            var b = new StateBuffer { DelayS = 0.05 };
            // server clock 100 s ahead of ours, 10 ms network delay, frames every 1/60 s
            for (int i = 0; i < 10; i++) b.Add(Frame(100 + i / 60.0, i), i / 60.0 + 0.01);
            var into = new InterpolatedState();
            double local = 9 / 60.0 + 0.01; // when the newest arrived
            Assert.IsTrue(b.Sample(local, into));
            double renderT = 100 + 9 / 60.0 - 0.05;
            Assert.AreEqual(renderT, into.ServerT, 1e-9);
            Assert.AreEqual((renderT - 100) * 60, into.Hip.X, 1e-6); // hip.x = frame index, linear in t
            Assert.IsFalse(into.Extrapolated);
        }

        [Test]
        public void ExtrapolatesAtMostTheBound()
        {
            var b = new StateBuffer { DelayS = 0, MaxExtrapolationS = 0.1 };
            b.Add(Frame(10.0, 0), 0.0);
            b.Add(Frame(10.1, 1), 0.1);
            var into = new InterpolatedState();
            b.Sample(0.15, into);
            Assert.IsTrue(into.Extrapolated);
            Assert.AreEqual(1.5, into.Hip.X, 1e-9);
            b.Sample(5.0, into); // the server went quiet: hold at the bound
            Assert.AreEqual(2.0, into.Hip.X, 1e-9);
        }

        [Test]
        public void DropsFramesOutOfOrderAndInterpolatesObjects()
        {
            var b = new StateBuffer { DelayS = 0 };
            var q0 = Quat.Identity;
            var q1 = new Quat(Math.Cos(0.5), 0, 0, Math.Sin(0.5)); // 1 rad about z
            b.Add(Frame(1.0, 0, new ObjectPose { Id = "cube", Pos = new Vec3(0, 0, 0), Rot = q0 }), 0);
            b.Add(Frame(2.0, 10, new ObjectPose { Id = "cube", Pos = new Vec3(0, 2, 0), Rot = q1 }), 1);
            b.Add(Frame(1.5, 99), 1.01);
            Assert.AreEqual(2, b.Count);
            var into = new InterpolatedState();
            b.Sample(0.5, into);
            Assert.AreEqual(5, into.Hip.X, 1e-9);
            var cube = into.Objects["cube"];
            Assert.AreEqual(1.0, cube.Pos.Y, 1e-9);
            Assert.AreEqual(Math.Cos(0.25), cube.Rot.W, 1e-9); // half the angle
        }
    }

    [TestFixture]
    public class BackoffAndPointTests
    {
        [Test]
        public void BackoffGrowsToItsCapAndResets()
        {
            var b = new Backoff(new Random(1)) { InitialS = 0.25, MaxS = 2, Factor = 2, Jitter = 0 };
            CollectionAssert.AreEqual(new[] { 0.25, 0.5, 1, 2, 2 }, Enumerable.Range(0, 5).Select(_ => b.NextDelayS()).ToArray());
            b.Reset();
            Assert.AreEqual(0.25, b.NextDelayS());
            var j = new Backoff(new Random(2)) { InitialS = 1, Jitter = 0.2 };
            var d = j.NextDelayS();
            Assert.That(d, Is.InRange(0.8, 1.2));
        }

        [Test]
        public void PointNamesFollowTheOneScheme()
        {
            Assert.IsTrue(TrackedPoints.IsPointName("right.index.tip"));
            Assert.IsTrue(TrackedPoints.IsPointName("left.palm"));
            Assert.IsFalse(TrackedPoints.IsPointName("right.thumb.intermediate"));
            Assert.IsFalse(TrackedPoints.IsPointName("index.tip"));
            Assert.AreEqual("right.index.distal", TrackedPoints.FromWebXR("right", "index-finger-phalanx-distal"));
            Assert.AreEqual("left.thumb.tip", TrackedPoints.FromWebXR("left", "thumb-tip"));
            Assert.AreEqual("right.wrist", TrackedPoints.FromWebXR("right", "wrist"));
            Assert.IsNull(TrackedPoints.FromWebXR("right", "elbow"));
        }
    }
}
