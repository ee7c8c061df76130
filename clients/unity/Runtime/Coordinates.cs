// Scene frame (x toward the viewer, y right, z up; right-handed) ↔ Unity (left-handed, y up,
// z away from the viewer), per docs/protocol.md "Coordinates". Plain numbers, so the core stays
// free of UnityEngine; the adapters wrap them in Vector3/Quaternion.
namespace Viestac.Client
{
    public static class Coordinates
    {
        /// <summary>Scene (x, y, z) → Unity (X, Y, Z) = (y, z, −x).</summary>
        public static void ToUnity(Vec3 p, out float x, out float y, out float z)
        {
            x = (float)p.Y; y = (float)p.Z; z = (float)-p.X;
        }

        public static Vec3 ToUnity(Vec3 p) { return new Vec3(p.Y, p.Z, -p.X); }

        /// <summary>Unity (X, Y, Z) → scene (x, y, z) = (−Z, X, Y).</summary>
        public static Vec3 FromUnity(double x, double y, double z) { return new Vec3(-z, x, y); }

        /// <summary>Scene [w, x, y, z] → Unity Quaternion(x = −y, y = −z, z = x, w = w): the
        /// mirror of the x axis flips the vector part's sign on the two unmirrored axes.</summary>
        public static void ToUnity(Quat q, out float x, out float y, out float z, out float w)
        {
            x = (float)-q.Y; y = (float)-q.Z; z = (float)q.X; w = (float)q.W;
        }

        /// <summary>Unity Quaternion (x, y, z, w) → scene [w, x, y, z] = [w, z, −x, −y].</summary>
        public static Quat FromUnity(double x, double y, double z, double w) { return new Quat(w, z, -x, -y); }

        /// <summary>A scale along the scene axes (sx, sy, sz) → Unity's local scale (sy, sz, sx): a size, not a direction, so no sign.</summary>
        public static Vec3 ScaleToUnity(Vec3 s) { return new Vec3(s.Y, s.Z, s.X); }
    }
}
