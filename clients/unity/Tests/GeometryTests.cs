using System;
using System.Collections.Generic;
using System.Linq;
using NUnit.Framework;

namespace Viestac.Client.Tests
{
    [TestFixture]
    public class GeometryTests
    {
        static Shape S(string type, double r = 0, double h = 0, params double[] size) { return new Shape { Type = type, Radius = r, Height = h, Size = size }; }

        static IEnumerable<object[]> Shapes()
        {
            yield return new object[] { S("sphere", 0.5), new Vec3(0, 0, 0), -0.5, 0.5 };
            yield return new object[] { S("hemisphere", 0.6), new Vec3(0, 0, 0.3), 0, 0.6 };
            yield return new object[] { S("cylinder", 0.2, 1.0), new Vec3(0, 0, 0.5), 0, 1.0 };
            yield return new object[] { S("cone", 0.3, 0.9), new Vec3(0, 0, 0.3), 0, 0.9 };
            yield return new object[] { S("box", 0, 0, 0.4, 0.6, 0.8), new Vec3(0, 0, 0), -0.4, 0.4 };
        }

        [Test]
        public void EveryPrimitiveIsClosedFacingOutwardInUnityAndSpansItsDeclaredHeight()
        {
            foreach (var c in Shapes())
            {
                var shape = (Shape)c[0]; var inside = Coordinates.ToUnity((Vec3)c[1]);
                var scene = ShapeMesh.For(shape);
                // scene-frame extent along z (Unity's y): cylinder and cone stand on z = 0
                Assert.AreEqual(Convert.ToDouble(c[2]), scene.Vertices.Min(v => v.Z), 1e-9, shape.Type);
                Assert.AreEqual(Convert.ToDouble(c[3]), scene.Vertices.Max(v => v.Z), 1e-9, shape.Type);
                var u = scene.ToUnity();
                Assert.AreEqual(Convert.ToDouble(c[3]), u.Vertices.Max(v => v.Y), 1e-9, shape.Type + " up is Unity's y");
                Assert.That(u.Triangles.Count, Is.GreaterThan(0));
                double area = 0;
                for (int i = 0; i < u.Triangles.Count; i += 3)
                {
                    Vec3 a = u.Vertices[u.Triangles[i]], b = u.Vertices[u.Triangles[i + 1]], cc = u.Vertices[u.Triangles[i + 2]];
                    var n = ShapeMesh.Cross(ShapeMesh.Sub(b, a), ShapeMesh.Sub(cc, a));
                    Assert.That(n.X * n.X + n.Y * n.Y + n.Z * n.Z, Is.GreaterThan(0), shape.Type + ": no degenerate triangles");
                    var centroid = new Vec3((a.X + b.X + cc.X) / 3, (a.Y + b.Y + cc.Y) / 3, (a.Z + b.Z + cc.Z) / 3);
                    // Unity's front face is clockwise seen from the front: the numeric cross points out
                    Assert.That(ShapeMesh.Dot(n, ShapeMesh.Sub(centroid, inside)), Is.GreaterThan(0), shape.Type + " triangle " + i / 3);
                    var vn = u.Normals[u.Triangles[i]];
                    Assert.That(ShapeMesh.Dot(vn, n), Is.GreaterThan(0), shape.Type + ": normals agree with the winding");
                    area += Math.Sqrt(ShapeMesh.Dot(n, n)) / 2;
                }
                Assert.That(area, Is.GreaterThan(0));
            }
        }

        [Test]
        public void SphereAreaApproachesFourPiRSquared()
        {
            var m = ShapeMesh.For(S("sphere", 1));
            double area = 0;
            for (int i = 0; i < m.Triangles.Count; i += 3)
            {
                Vec3 a = m.Vertices[m.Triangles[i]], b = m.Vertices[m.Triangles[i + 1]], c = m.Vertices[m.Triangles[i + 2]];
                var n = ShapeMesh.Cross(ShapeMesh.Sub(b, a), ShapeMesh.Sub(c, a));
                area += Math.Sqrt(ShapeMesh.Dot(n, n)) / 2;
            }
            Assert.AreEqual(4 * Math.PI, area, 0.05 * 4 * Math.PI);
        }

        [Test]
        public void MeshesAreFlatShadedAndPlanesFaceUp()
        {
            var mesh = new Shape { Type = "mesh" };
            mesh.Vertices.AddRange(new[] { new Vec3(0, 0, 0), new Vec3(1, 0, 0), new Vec3(0, 1, 0) });
            mesh.Faces.Add(new[] { 0, 1, 2 });
            var m = ShapeMesh.For(mesh);
            Assert.AreEqual(3, m.Vertices.Count);
            Assert.AreEqual(1.0, m.Normals[0].Z, 1e-12);
            var plane = ShapeMesh.For(S("plane", 0, 0, 3, 2)).ToUnity();
            Assert.IsTrue(plane.Normals.All(n => Math.Abs(n.Y - 1) < 1e-12), "the ground faces Unity's up");
            Assert.AreEqual(1.5, plane.Vertices.Max(v => -v.Z), 1e-12, "sx along the scene's x, Unity's −z");
            Assert.IsNull(ShapeMesh.For(S("torus", 1)));
        }

        [Test]
        public void AngleScaleTicksAndLabelsSitOnTheProtractor()
        {
            var o = new Overlay { Kind = "angle_scale", Centre = new Vec3(0, 0, 0.35), Radius = 0.9, FromDeg = -90, ToDeg = 90, MinorDeg = 10, MajorDeg = 30 };
            var g = AngleScaleGeometry.For(o);
            Assert.AreEqual(19 * 2, g.Ticks.Count);
            CollectionAssert.AreEqual(new[] { "-90°", "-60°", "-30°", "0°", "30°", "60°", "90°" }, g.Labels.Select(l => l.Value).ToArray());
            var left = g.Ticks[0]; // −90: left of the centre
            Assert.AreEqual(-0.9, left.Y, 1e-12); Assert.AreEqual(0.35, left.Z, 1e-12);
            var top = g.Labels[3].Key;
            Assert.AreEqual(0, top.Y, 1e-12); Assert.That(top.Z, Is.GreaterThan(0.35 + 0.9));
        }
    }
}
