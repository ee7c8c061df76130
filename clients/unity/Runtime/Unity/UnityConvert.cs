// The only place the core's numbers become UnityEngine types (docs/protocol.md "Coordinates").
using UnityEngine;
using Viestac.Client;

namespace Viestac.Unity
{
    public static class UnityConvert
    {
        public static Vector3 Position(Vec3 p) { float x, y, z; Coordinates.ToUnity(p, out x, out y, out z); return new Vector3(x, y, z); }
        public static Quaternion Rotation(Quat q) { float x, y, z, w; Coordinates.ToUnity(q, out x, out y, out z, out w); return new Quaternion(x, y, z, w); }
        public static Vec3 ScenePosition(Vector3 p) { return Coordinates.FromUnity(p.x, p.y, p.z); }
        public static Quat SceneRotation(Quaternion q) { return Coordinates.FromUnity(q.x, q.y, q.z, q.w); }
        public static Vector3 Scale(Vec3 s) { var u = Coordinates.ScaleToUnity(s); return new Vector3((float)u.X, (float)u.Y, (float)u.Z); }

        public static Color Colour(string hex, double opacity = 1)
        {
            Color c;
            if (hex == null || !ColorUtility.TryParseHtmlString(hex, out c)) c = Color.gray;
            c.a = (float)opacity;
            return c;
        }

        /// <summary>The Standard shader's "Fade" mode: a colour's alpha shows only with blending on.</summary>
        public static void MakeTransparent(UnityEngine.Material m)
        {
            m.SetFloat("_Mode", 2);
            m.SetInt("_SrcBlend", (int)UnityEngine.Rendering.BlendMode.SrcAlpha);
            m.SetInt("_DstBlend", (int)UnityEngine.Rendering.BlendMode.OneMinusSrcAlpha);
            m.SetInt("_ZWrite", 0);
            m.DisableKeyword("_ALPHATEST_ON");
            m.EnableKeyword("_ALPHABLEND_ON");
            m.DisableKeyword("_ALPHAPREMULTIPLY_ON");
            m.renderQueue = (int)UnityEngine.Rendering.RenderQueue.Transparent;
        }

        public static Mesh Mesh(ShapeMesh sceneMesh)
        {
            var u = sceneMesh.ToUnity();
            var vertices = new Vector3[u.Vertices.Count];
            var normals = new Vector3[u.Normals.Count];
            for (int i = 0; i < vertices.Length; i++)
            {
                vertices[i] = new Vector3((float)u.Vertices[i].X, (float)u.Vertices[i].Y, (float)u.Vertices[i].Z);
                normals[i] = new Vector3((float)u.Normals[i].X, (float)u.Normals[i].Y, (float)u.Normals[i].Z);
            }
            var mesh = new Mesh();
            if (vertices.Length > 65535) mesh.indexFormat = UnityEngine.Rendering.IndexFormat.UInt32;
            mesh.vertices = vertices;
            mesh.normals = normals;
            mesh.triangles = u.Triangles.ToArray();
            mesh.RecalculateBounds();
            return mesh;
        }
    }
}
