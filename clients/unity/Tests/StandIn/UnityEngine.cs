// TEST-ONLY stand-in for the UnityEngine types the adapters in Runtime/Unity use, with Unity's
// member names and signatures, so that the adapters compile here (a typo or a wrong type still
// fails the build). It does nothing useful at run time and never ships: Unity brings the real ones.
#pragma warning disable 67, 414, 649
using System;

namespace UnityEngine
{
    public struct Vector3
    {
        public float x, y, z;
        public Vector3(float x, float y, float z) { this.x = x; this.y = y; this.z = z; }
        public static Vector3 operator +(Vector3 a, Vector3 b) { return new Vector3(a.x + b.x, a.y + b.y, a.z + b.z); }
        public static Vector3 operator -(Vector3 a, Vector3 b) { return new Vector3(a.x - b.x, a.y - b.y, a.z - b.z); }
        public static Vector3 operator *(Vector3 a, float s) { return new Vector3(a.x * s, a.y * s, a.z * s); }
        public static Vector3 zero { get { return new Vector3(); } }
        public static Vector3 one { get { return new Vector3(1, 1, 1); } }
        public static Vector3 up { get { return new Vector3(0, 1, 0); } }
    }

    public struct Quaternion
    {
        public float x, y, z, w;
        public Quaternion(float x, float y, float z, float w) { this.x = x; this.y = y; this.z = z; this.w = w; }
        public static Quaternion identity { get { return new Quaternion(0, 0, 0, 1); } }
        public static Quaternion Inverse(Quaternion q) { return new Quaternion(-q.x, -q.y, -q.z, q.w); }
        public static Quaternion operator *(Quaternion a, Quaternion b)
        {
            return new Quaternion(a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y, a.w * b.y + a.y * b.w + a.z * b.x - a.x * b.z,
                                  a.w * b.z + a.z * b.w + a.x * b.y - a.y * b.x, a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z);
        }
        public static Vector3 operator *(Quaternion q, Vector3 v) { return v; }
    }

    public struct Color
    {
        public float r, g, b, a;
        public Color(float r, float g, float b, float a = 1) { this.r = r; this.g = g; this.b = b; this.a = a; }
        public static Color gray { get { return new Color(0.5f, 0.5f, 0.5f); } }
        public static Color white { get { return new Color(1, 1, 1); } }
    }

    public static class ColorUtility
    {
        public static bool TryParseHtmlString(string htmlString, out Color color) { color = Color.white; return htmlString != null; }
    }

    public static class Mathf
    {
        public static float Max(float a, float b) { return Math.Max(a, b); }
    }

    public static class Time
    {
        public static float realtimeSinceStartup { get { return 0; } }
        public static float unscaledTime { get { return 0; } }
        public static float deltaTime { get { return 0; } }
    }

    public static class Application
    {
        public static string unityVersion { get { return "stand-in"; } }
    }

    public static class Debug
    {
        public static void Log(object message) { }
        public static void LogWarning(object message) { }
        public static void LogError(object message) { }
    }

    [AttributeUsage(AttributeTargets.Field)]
    public sealed class TooltipAttribute : Attribute { public TooltipAttribute(string tooltip) { } }

    [AttributeUsage(AttributeTargets.Field)]
    public sealed class SerializeField : Attribute { }

    public class Object
    {
        public string name;
        public static void Destroy(Object obj) { }
    }

    public sealed class GameObject : Object
    {
        public GameObject() { }
        public GameObject(string name) { this.name = name; }
        public Transform transform { get { return null; } }
        public T AddComponent<T>() where T : Component, new() { return new T(); }
        public T GetComponent<T>() where T : Component { return null; }
        public void SetActive(bool value) { }
        public bool activeSelf { get { return true; } }
        public bool activeInHierarchy { get { return true; } }
    }

    public class Component : Object
    {
        public Transform transform { get { return null; } }
        public GameObject gameObject { get { return null; } }
        public T GetComponent<T>() where T : Component { return null; }
    }

    public class Behaviour : Component { public bool enabled; }
    public class MonoBehaviour : Behaviour { }

    public class Transform : Component
    {
        public Vector3 position, localPosition, localScale;
        public Quaternion rotation, localRotation;
        public Transform parent { get { return null; } }
        public void SetParent(Transform parent, bool worldPositionStays) { }
        public Vector3 InverseTransformPoint(Vector3 position) { return position; }
        public Vector3 TransformPoint(Vector3 position) { return position; }
        public Vector3 TransformDirection(Vector3 direction) { return direction; }
        public void LookAt(Vector3 worldPosition, Vector3 worldUp) { }
    }

    public sealed class Shader : Object
    {
        public static Shader Find(string name) { return new Shader(); }
    }

    public class Material : Object
    {
        public Material(Shader shader) { }
        public Material(Material source) { }
        public Color color;
        public int renderQueue;
        public void SetFloat(string name, float value) { }
        public void SetInt(string name, int value) { }
        public void EnableKeyword(string keyword) { }
        public void DisableKeyword(string keyword) { }
    }

    public sealed class Mesh : Object
    {
        public Vector3[] vertices, normals;
        public int[] triangles;
        public Rendering.IndexFormat indexFormat;
        public void RecalculateBounds() { }
        public void RecalculateNormals() { }
    }

    public sealed class MeshFilter : Component { public Mesh sharedMesh, mesh; }
    public class Renderer : Component { public Material sharedMaterial, material; public bool enabled; }
    public sealed class MeshRenderer : Renderer { }

    public sealed class LineRenderer : Renderer
    {
        public bool useWorldSpace;
        public int positionCount;
        public float startWidth, endWidth;
        public Color startColor, endColor;
        public void SetPosition(int index, Vector3 position) { }
    }

    public enum TextAnchor { UpperLeft, UpperCenter, UpperRight, MiddleLeft, MiddleCenter, MiddleRight, LowerLeft, LowerCenter, LowerRight }

    public sealed class TextMesh : Component
    {
        public string text;
        public float characterSize;
        public TextAnchor anchor;
        public Color color;
    }

    public sealed class Camera : Behaviour
    {
        public bool orthographic;
        public float orthographicSize, fieldOfView;
        public static Camera main { get { return null; } }
    }
}

namespace UnityEngine.Rendering
{
    public enum IndexFormat { UInt16, UInt32 }
    public enum BlendMode { Zero = 0, One = 1, SrcAlpha = 5, OneMinusSrcAlpha = 10 }
    public enum RenderQueue { Transparent = 3000 }
}
