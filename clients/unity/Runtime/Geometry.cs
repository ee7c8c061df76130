// Triangle meshes of the scene's shapes and the lines of its overlays, built here (not in the
// Unity adapter) so they are tested: local geometry per docs/protocol.md "Scene format", counter-
// clockwise seen from outside in the scene frame; ToUnity() converts and reverses the winding
// (the frame change is a mirror), so that Unity's clockwise front faces face outward.
using System;
using System.Collections.Generic;

namespace Viestac.Client
{
    public sealed class ShapeMesh
    {
        public readonly List<Vec3> Vertices = new List<Vec3>();
        public readonly List<Vec3> Normals = new List<Vec3>();
        public readonly List<int> Triangles = new List<int>();

        public const int Segments = 32;

        /// <summary>The mesh of a shape in its local frame (scene axes); null for an unknown type.</summary>
        public static ShapeMesh For(Shape s)
        {
            var m = new ShapeMesh();
            double r = s.Radius, h = s.Height;
            switch (s.Type)
            {
                case "sphere":
                {
                    var profile = new List<double[]>();
                    for (int i = 0; i <= Segments / 2; i++)
                    {
                        double th = Math.PI * i / (Segments / 2);
                        profile.Add(new[] { r * Math.Sin(th), r * Math.Cos(th), Math.Sin(th), Math.Cos(th) });
                    }
                    m.Revolve(profile);
                    break;
                }
                case "hemisphere":
                {
                    var profile = new List<double[]>();
                    for (int i = 0; i <= Segments / 4; i++)
                    {
                        double th = Math.PI / 2 * i / (Segments / 4);
                        profile.Add(new[] { r * Math.Sin(th), r * Math.Cos(th), Math.Sin(th), Math.Cos(th) });
                    }
                    m.Revolve(profile);
                    m.Disc(0, r, false);
                    break;
                }
                case "cylinder":
                    m.Revolve(new List<double[]> { new[] { r, h, 1.0, 0 }, new[] { r, 0, 1.0, 0 } });
                    m.Disc(h, r, true);
                    m.Disc(0, r, false);
                    break;
                case "cone":
                {
                    double n = Math.Sqrt(h * h + r * r);
                    m.Revolve(new List<double[]> { new[] { 0, h, h / n, r / n }, new[] { r, 0, h / n, r / n } });
                    m.Disc(0, r, false);
                    break;
                }
                case "box":
                {
                    double hx = Size(s, 0) / 2, hy = Size(s, 1) / 2, hz = Size(s, 2) / 2;
                    m.Face(new Vec3(hx, 0, 0), new Vec3(0, hy, 0), new Vec3(0, 0, hz));
                    m.Face(new Vec3(-hx, 0, 0), new Vec3(0, 0, hz), new Vec3(0, hy, 0));
                    m.Face(new Vec3(0, hy, 0), new Vec3(0, 0, hz), new Vec3(hx, 0, 0));
                    m.Face(new Vec3(0, -hy, 0), new Vec3(hx, 0, 0), new Vec3(0, 0, hz));
                    m.Face(new Vec3(0, 0, hz), new Vec3(hx, 0, 0), new Vec3(0, hy, 0));
                    m.Face(new Vec3(0, 0, -hz), new Vec3(0, hy, 0), new Vec3(hx, 0, 0));
                    break;
                }
                case "plane": // the top face at z = 0; the solid below is never seen from above
                    m.Face(new Vec3(0, 0, 0), new Vec3(Size(s, 0) / 2, 0, 0), new Vec3(0, Size(s, 1) / 2, 0));
                    break;
                case "mesh": // flat-shaded: three vertices of its own per face
                    foreach (var f in s.Faces)
                    {
                        Vec3 a = s.Vertices[f[0]], b = s.Vertices[f[1]], c = s.Vertices[f[2]];
                        var n = Normalise(Cross(Sub(b, a), Sub(c, a)));
                        m.Tri(a, b, c, n, n, n);
                    }
                    break;
                default: return null;
            }
            return m;
        }

        static double Size(Shape s, int i) { return i < s.Size.Length ? s.Size[i] : 0; }

        /// <summary>A surface of revolution about +z: profile rows of [radius, z, normal_r, normal_z], top to bottom.</summary>
        void Revolve(List<double[]> profile)
        {
            int start = Vertices.Count;
            foreach (var p in profile)
                for (int j = 0; j <= Segments; j++)
                {
                    double phi = 2 * Math.PI * j / Segments, c = Math.Cos(phi), s = Math.Sin(phi);
                    Vertices.Add(new Vec3(p[0] * c, p[0] * s, p[1]));
                    Normals.Add(new Vec3(p[2] * c, p[2] * s, p[3]));
                }
            int row = Segments + 1;
            for (int i = 0; i + 1 < profile.Count; i++)
                for (int j = 0; j < Segments; j++)
                {
                    int a = start + i * row + j, b = a + row, c = b + 1, d = a + 1;
                    if (profile[i + 1][0] > 0) { Triangles.Add(a); Triangles.Add(b); Triangles.Add(c); }
                    if (profile[i][0] > 0) { Triangles.Add(a); Triangles.Add(c); Triangles.Add(d); }
                }
        }

        void Disc(double z, double r, bool up)
        {
            int centre = Vertices.Count;
            var n = new Vec3(0, 0, up ? 1 : -1);
            Vertices.Add(new Vec3(0, 0, z)); Normals.Add(n);
            for (int j = 0; j <= Segments; j++)
            {
                double phi = 2 * Math.PI * j / Segments;
                Vertices.Add(new Vec3(r * Math.Cos(phi), r * Math.Sin(phi), z)); Normals.Add(n);
            }
            for (int j = 0; j < Segments; j++)
            {
                Triangles.Add(centre);
                Triangles.Add(centre + 1 + (up ? j : j + 1));
                Triangles.Add(centre + 1 + (up ? j + 1 : j));
            }
        }

        /// <summary>A rectangle centred at `c` spanning ±u, ±v, facing u × v.</summary>
        void Face(Vec3 c, Vec3 u, Vec3 v)
        {
            var n = Normalise(Cross(u, v));
            Vec3 p0 = Add(c, -1, u, -1, v), p1 = Add(c, 1, u, -1, v), p2 = Add(c, 1, u, 1, v), p3 = Add(c, -1, u, 1, v);
            Tri(p0, p1, p2, n, n, n);
            Tri(p0, p2, p3, n, n, n);
        }

        void Tri(Vec3 a, Vec3 b, Vec3 c, Vec3 na, Vec3 nb, Vec3 nc)
        {
            int i = Vertices.Count;
            Vertices.Add(a); Vertices.Add(b); Vertices.Add(c);
            Normals.Add(na); Normals.Add(nb); Normals.Add(nc);
            Triangles.Add(i); Triangles.Add(i + 1); Triangles.Add(i + 2);
        }

        /// <summary>The same mesh in Unity's frame, winding reversed (clockwise front faces).</summary>
        public ShapeMesh ToUnity()
        {
            var u = new ShapeMesh();
            foreach (var v in Vertices) u.Vertices.Add(Coordinates.ToUnity(v));
            foreach (var n in Normals) u.Normals.Add(Coordinates.ToUnity(n));
            for (int i = 0; i < Triangles.Count; i += 3)
            {
                u.Triangles.Add(Triangles[i]); u.Triangles.Add(Triangles[i + 2]); u.Triangles.Add(Triangles[i + 1]);
            }
            return u;
        }

        public static Vec3 Sub(Vec3 a, Vec3 b) { return new Vec3(a.X - b.X, a.Y - b.Y, a.Z - b.Z); }
        public static Vec3 Cross(Vec3 a, Vec3 b) { return new Vec3(a.Y * b.Z - a.Z * b.Y, a.Z * b.X - a.X * b.Z, a.X * b.Y - a.Y * b.X); }
        public static double Dot(Vec3 a, Vec3 b) { return a.X * b.X + a.Y * b.Y + a.Z * b.Z; }
        static Vec3 Add(Vec3 c, double su, Vec3 u, double sv, Vec3 v) { return new Vec3(c.X + su * u.X + sv * v.X, c.Y + su * u.Y + sv * v.Y, c.Z + su * u.Z + sv * v.Z); }
        static Vec3 Normalise(Vec3 v)
        {
            double n = Math.Sqrt(Dot(v, v));
            return n > 0 ? new Vec3(v.X / n, v.Y / n, v.Z / n) : v;
        }
    }

    /// <summary>The lines and labels of an `angle_scale` overlay: a protractor in the y-z plane,
    /// angle a at centre + radius·(0, sin a, cos a) (docs/protocol.md "Scene format").</summary>
    public sealed class AngleScaleGeometry
    {
        public readonly List<Vec3> ArcPoints = new List<Vec3>();
        /// <summary>Pairs of points: each tick from the arc outward.</summary>
        public readonly List<Vec3> Ticks = new List<Vec3>();
        public readonly List<KeyValuePair<Vec3, string>> Labels = new List<KeyValuePair<Vec3, string>>();

        public static AngleScaleGeometry For(Overlay o)
        {
            var g = new AngleScaleGeometry();
            Func<double, double, Vec3> at = (deg, radius) =>
            {
                double a = deg * Math.PI / 180;
                return new Vec3(o.Centre.X, o.Centre.Y + radius * Math.Sin(a), o.Centre.Z + radius * Math.Cos(a));
            };
            for (double d = o.FromDeg; d <= o.ToDeg + 1e-9; d += 2) g.ArcPoints.Add(at(d, o.Radius));
            if (o.MinorDeg <= 0) return g;
            int steps = (int)Math.Floor((o.ToDeg - o.FromDeg) / o.MinorDeg + 1e-9);
            for (int i = 0; i <= steps; i++)
            {
                double d = o.FromDeg + i * o.MinorDeg;
                bool major = o.MajorDeg > 0 && Math.Abs(Math.IEEERemainder(d, o.MajorDeg)) < 1e-6;
                g.Ticks.Add(at(d, o.Radius));
                g.Ticks.Add(at(d, o.Radius * (major ? 1.08 : 1.04)));
                if (major) g.Labels.Add(new KeyValuePair<Vec3, string>(at(d, o.Radius * 1.16), ((int)Math.Round(d)).ToString(System.Globalization.CultureInfo.InvariantCulture) + "°"));
            }
            return g;
        }
    }
}
