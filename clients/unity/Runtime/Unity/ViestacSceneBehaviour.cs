// Thin adapter: builds GameObjects from the server's scene and applies each state. Everything it
// computes comes from the core (Viestac.Client); only the UnityEngine calls live here.
using System.Collections.Generic;
using UnityEngine;
using Viestac.Client;
using Material = UnityEngine.Material;

namespace Viestac.Unity
{
    public class ViestacSceneBehaviour : MonoBehaviour
    {
        [Tooltip("ws://HOST:PORT/ws (wss:// with TLS)")] public string url = "ws://127.0.0.1:8000/ws";
        [Tooltip("The access token (docs/security.md); never put it in the URL")] public string token = "";
        public string role = Roles.Observer;
        [Tooltip("Material to copy for every object (its colour is set per object); null: the Standard shader")] public Material baseMaterial;
        [Tooltip("Set the camera from the scene's camera")] public Camera sceneCamera;
        [Tooltip("Shows the HUD text")] public TextMesh hud;
        public bool interpolate = true;

        public ViestacSession Session { get; private set; }
        public Scene Scene { get; private set; }
        public StateFrame Latest { get; private set; }
        public string HudText { get; private set; }
        /// <summary>The parent of everything built: 1 scene unit = 1 Unity unit.</summary>
        public Transform Root { get; private set; }

        readonly Dictionary<string, GameObject> _objects = new Dictionary<string, GameObject>();
        readonly Dictionary<string, Vector3> _baseScales = new Dictionary<string, Vector3>();
        readonly StateBuffer _buffer = new StateBuffer();
        readonly InterpolatedState _sample = new InterpolatedState();
        readonly StateFrame _latest = new StateFrame();
        Transform _hip, _proxy;
        bool _haveState;
        // v1.4: the other tools (state.tools after the primary) and the hand's points, by name;
        // built once per name and hidden while absent from the newest frame
        sealed class Marker { public Transform T; public long Frame; }
        readonly Dictionary<string, Marker> _toolHips = new Dictionary<string, Marker>(), _toolProxies = new Dictionary<string, Marker>(),
                                            _points = new Dictionary<string, Marker>();

        void Start()
        {
            Session = new ViestacSession(new SessionOptions
            {
                Url = new System.Uri(url), Token = token, Role = role, ClientName = "viestac-unity/" + Application.unityVersion,
                Log = Debug.LogWarning,
            });
            Session.SceneReceived += OnScene;
            Session.StateReceived += OnState;
            Session.ErrorReceived += e => Debug.LogWarning("ViESTac server: " + e.Code + ": " + e.Message);
            Session.StatusChanged += (s, why) => Debug.Log("ViESTac " + s + " " + why);
            Session.Start();
        }

        void Update()
        {
            Session.Drain();
            if (!_haveState) return;
            if (interpolate && _buffer.Sample(Session.NowS, _sample))
            {
                Place(_hip, _sample.Hip);
                Place(_proxy, _sample.Proxy);
                foreach (var kv in _sample.Objects) Pose(kv.Key, kv.Value.Pos, kv.Value.Rot);
            }
            else
            {
                Place(_hip, _latest.Hip);
                Place(_proxy, _latest.Proxy);
                foreach (var o in _latest.Objects) Pose(o.Id, o.Pos, o.Rot);
            }
            PlaceToolsAndPoints(_latest);
        }

        /// <summary>Every tool but the primary (drawn above as the HIP and proxy) and every point
        /// that drives no tool, from the newest frame; a lost tool is hidden (it waits at home).</summary>
        void PlaceToolsAndPoints(StateFrame s)
        {
            var colour = UnityConvert.Colour(Scene.Hip.Color);
            for (int i = 1; i < s.Tools.Count; i++)
            {
                var tool = s.Tools[i];
                Show(_toolHips, tool.Name, "tool " + tool.Name, Scene.Hip.Radius, colour, tool.Hip, s.Frame, !tool.Lost);
                Show(_toolProxies, tool.Name, "proxy " + tool.Name, Scene.Hip.ProxyRadius, new Color(colour.r, colour.g, colour.b, 0.35f), tool.Proxy, s.Frame, !tool.Lost);
            }
            foreach (var kv in s.Points) Show(_points, kv.Key, "point " + kv.Key, Scene.Hip.Radius * 0.4, colour, kv.Value, s.Frame, true);
            HideStale(_toolHips, s.Frame); HideStale(_toolProxies, s.Frame); HideStale(_points, s.Frame);
        }

        void Show(Dictionary<string, Marker> markers, string key, string name, double radius, Color colour, Vec3 p, long frame, bool visible)
        {
            Marker m;
            if (!markers.TryGetValue(key, out m)) markers[key] = m = new Marker { T = Ball(name, radius, colour) };
            m.Frame = frame;
            m.T.gameObject.SetActive(visible && radius > 0);
            Place(m.T, p);
        }

        static void HideStale(Dictionary<string, Marker> markers, long frame)
        {
            foreach (var kv in markers) if (kv.Value.Frame != frame) kv.Value.T.gameObject.SetActive(false);
        }

        void OnDestroy() { if (Session != null) Session.Dispose(); }

        void OnScene(SceneMessage m)
        {
            foreach (var w in m.Scene.Warnings) Debug.LogWarning("ViESTac scene: " + w);
            if (Root != null) Destroy(Root.gameObject);
            _objects.Clear(); _baseScales.Clear(); _buffer.Clear(); _haveState = false;
            _toolHips.Clear(); _toolProxies.Clear(); _points.Clear();
            Scene = m.Scene;
            Root = new GameObject("ViESTac scene " + Scene.Name).transform;
            Root.SetParent(transform, false);
            foreach (var o in Scene.Objects) Build(o);
            foreach (var ov in Scene.Overlays) BuildOverlay(ov);
            _hip = Ball("HIP", Scene.Hip.Radius, UnityConvert.Colour(Scene.Hip.Color));
            _proxy = Ball("proxy", Scene.Hip.ProxyRadius, UnityConvert.Colour(Scene.Hip.Color, 0.35));
            if (sceneCamera != null) ApplyCamera(Scene.Camera);
        }

        void Build(SceneObject o)
        {
            var mesh = ShapeMesh.For(o.Shape);
            if (mesh == null) return;
            var go = new GameObject(o.Id);
            go.transform.SetParent(Root, false);
            go.AddComponent<MeshFilter>().sharedMesh = UnityConvert.Mesh(mesh);
            go.AddComponent<MeshRenderer>().sharedMaterial = MaterialFor(o.Material);
            go.transform.localPosition = UnityConvert.Position(o.Pos);
            go.transform.localRotation = UnityConvert.Rotation(o.Rot);
            go.SetActive(o.Visible);
            _objects[o.Id] = go;
            _baseScales[o.Id] = go.transform.localScale;
        }

        void BuildOverlay(Overlay ov)
        {
            var go = new GameObject(ov.Id);
            go.transform.SetParent(Root, false);
            var colour = UnityConvert.Colour(ov.Color);
            if (ov.Kind == "label")
            {
                Label(go.transform, ov.Pos, ov.Text, ov.Size, colour);
            }
            else if (ov.Kind == "angle_scale")
            {
                var g = AngleScaleGeometry.For(ov);
                var arc = go.AddComponent<LineRenderer>();
                arc.useWorldSpace = false;
                arc.positionCount = g.ArcPoints.Count;
                for (int i = 0; i < g.ArcPoints.Count; i++) arc.SetPosition(i, UnityConvert.Position(g.ArcPoints[i]));
                arc.startWidth = arc.endWidth = 0.005f;
                arc.startColor = arc.endColor = colour;
                for (int i = 0; i < g.Ticks.Count; i += 2)
                {
                    var tick = new GameObject("tick").AddComponent<LineRenderer>();
                    tick.transform.SetParent(go.transform, false);
                    tick.useWorldSpace = false;
                    tick.positionCount = 2;
                    tick.SetPosition(0, UnityConvert.Position(g.Ticks[i]));
                    tick.SetPosition(1, UnityConvert.Position(g.Ticks[i + 1]));
                    tick.startWidth = tick.endWidth = 0.004f;
                    tick.startColor = tick.endColor = colour;
                }
                foreach (var l in g.Labels) Label(go.transform, l.Key, l.Value, ov.Radius * 0.08, colour);
            }
            go.SetActive(ov.Visible);
            _objects[ov.Id] = go;
            _baseScales[ov.Id] = go.transform.localScale;
        }

        static void Label(Transform parent, Vec3 pos, string text, double size, Color colour)
        {
            var t = new GameObject("label").AddComponent<TextMesh>();
            t.transform.SetParent(parent, false);
            t.transform.localPosition = UnityConvert.Position(pos);
            t.text = text;
            t.characterSize = (float)size;
            t.anchor = TextAnchor.MiddleCenter;
            t.color = colour;
        }

        Transform Ball(string name, double radius, Color colour)
        {
            var go = new GameObject(name);
            go.transform.SetParent(Root, false);
            go.AddComponent<MeshFilter>().sharedMesh = UnityConvert.Mesh(ShapeMesh.For(new Shape { Type = "sphere", Radius = radius }));
            var m = MaterialFor(new Client.Material { Color = "#ffffff", Opacity = colour.a });
            m.color = colour;
            go.AddComponent<MeshRenderer>().sharedMaterial = m;
            go.SetActive(radius > 0);
            return go.transform;
        }

        UnityEngine.Material MaterialFor(Client.Material m)
        {
            var mat = baseMaterial != null ? new UnityEngine.Material(baseMaterial) : new UnityEngine.Material(Shader.Find("Standard"));
            mat.color = UnityConvert.Colour(m.Color, m.Opacity);
            if (m.Opacity < 1) UnityConvert.MakeTransparent(mat);
            return mat;
        }

        void ApplyCamera(SceneCamera c)
        {
            // placed, not parented: the scene root is destroyed when the next scene comes
            var t = sceneCamera.transform;
            t.position = Root.TransformPoint(UnityConvert.Position(c.Position));
            t.LookAt(Root.TransformPoint(UnityConvert.Position(c.Target)), Root.TransformDirection(UnityConvert.Position(c.Up)));
            sceneCamera.orthographic = c.Projection == "orthographic";
            if (sceneCamera.orthographic) sceneCamera.orthographicSize = (float)(c.Height / 2);
            else sceneCamera.fieldOfView = (float)c.FovDeg;
        }

        void OnState(StateFrame s)
        {
            if (Scene == null) return; // the server sends the scene first; a state before it has nothing to apply to
            s.CopyTo(_latest);
            Latest = _latest;
            _haveState = true;
            _buffer.Add(s, s.ReceivedS); // stamped on arrival, not when Update got to it
            // visibility, scales and the HUD follow the newest frame (complete sets: absent = the scene's)
            foreach (var o in Scene.Objects) SetActive(o.Id, s.Visible, o.Visible);
            foreach (var o in Scene.Overlays) SetActive(o.Id, s.Visible, o.Visible);
            foreach (var kv in _objects)
            {
                Vec3 scale;
                kv.Value.transform.localScale = s.Scales.TryGetValue(kv.Key, out scale) ? UnityConvert.Scale(scale) : _baseScales[kv.Key];
            }
            HudText = s.Hud.Length > 0 ? s.Hud : Scene.HudText;
            if (hud != null) hud.text = HudText;
        }

        void SetActive(string id, Dictionary<string, bool> overrides, bool fromScene)
        {
            GameObject go;
            if (!_objects.TryGetValue(id, out go)) return;
            bool visible;
            go.SetActive(overrides.TryGetValue(id, out visible) ? visible : fromScene);
        }

        void Place(Transform t, Vec3 p) { if (t != null) t.localPosition = UnityConvert.Position(p); }

        void Pose(string id, Vec3 p, Quat q)
        {
            GameObject go;
            if (!_objects.TryGetValue(id, out go)) return;
            go.transform.localPosition = UnityConvert.Position(p);
            go.transform.localRotation = UnityConvert.Rotation(q);
        }
    }
}
