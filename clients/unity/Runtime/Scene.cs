// The scene model (docs/protocol.md "Scene format"): every shape, material, overlay and the
// camera, in the scene frame. Built from the decoded `scene` map; an invalid mesh is skipped with
// a warning and the rest of the scene drawn, as the protocol asks of clients.
using System;
using System.Collections.Generic;

namespace Viestac.Client
{
    public sealed class SceneCamera
    {
        public string Projection = "orthographic";
        public Vec3 Position = new Vec3(5, 0, 0), Target, Up = new Vec3(0, 0, 1);
        /// <summary>Orthographic: visible height in scene units.</summary>
        public double Height = 1;
        /// <summary>Perspective: vertical field of view.</summary>
        public double FovDeg = 50;
    }

    public sealed class HipStyle
    {
        public double Radius, ProxyRadius;
        public string Color = "#ffd400";
    }

    public sealed class Shape
    {
        /// <summary>sphere, box, cylinder, cone, plane, hemisphere, mesh.</summary>
        public string Type;
        public double Radius, Height;
        /// <summary>box: [sx, sy, sz]; plane: [sx, sy].</summary>
        public double[] Size = new double[0];
        public readonly List<Vec3> Vertices = new List<Vec3>();
        public readonly List<int[]> Faces = new List<int[]>();
    }

    public sealed class Material
    {
        public string Color = "#8c8c8c";
        public double Opacity = 1, StiffnessNPerM, StaticFriction, DynamicFriction;
        /// <summary>A skin image path on the server, or null; tiled every SkinTile[0] × SkinTile[1] scene units.</summary>
        public string SkinImage;
        public double[] SkinTile;
    }

    public sealed class SceneObject
    {
        public string Id;
        public Shape Shape;
        public Vec3 Pos;
        public Quat Rot = Quat.Identity;
        public Material Material = new Material();
        public bool Haptic = true, Visible = true;
    }

    /// <summary>`angle_scale` (a protractor in the y-z plane) or `label` (text facing the camera).</summary>
    public sealed class Overlay
    {
        public string Id, Kind, Color = "#ffffff", Text = "";
        public bool Visible = true;
        public Vec3 Centre, Pos;
        public double Radius, FromDeg = -90, ToDeg = 90, MinorDeg = 10, MajorDeg = 30, Size = 0.1;
    }

    public sealed class Scene
    {
        public const int MaxMeshVertices = 20000, MaxMeshFaces = 40000;
        public string Name = "";
        public SceneCamera Camera = new SceneCamera();
        public HipStyle Hip = new HipStyle();
        public readonly List<SceneObject> Objects = new List<SceneObject>();
        public readonly List<Overlay> Overlays = new List<Overlay>();
        public string HudText = "";
        /// <summary>What was skipped (an invalid mesh, an unknown shape), for a log line.</summary>
        public readonly List<string> Warnings = new List<string>();

        public SceneObject Find(string id)
        {
            foreach (var o in Objects) if (o.Id == id) return o;
            return null;
        }

        public static Scene FromMap(Dictionary<string, object> m)
        {
            var s = new Scene { Name = Field(m, "name") as string ?? "" };
            var cam = Field(m, "camera") as Dictionary<string, object>;
            if (cam != null)
            {
                s.Camera.Projection = Field(cam, "projection") as string ?? "orthographic";
                s.Camera.Position = OptVec(cam, "position", s.Camera.Position);
                s.Camera.Target = OptVec(cam, "target", s.Camera.Target);
                s.Camera.Up = OptVec(cam, "up", s.Camera.Up);
                s.Camera.Height = OptNum(cam, "height", s.Camera.Height);
                s.Camera.FovDeg = OptNum(cam, "fov_deg", s.Camera.FovDeg);
            }
            var hip = Field(m, "hip") as Dictionary<string, object>;
            if (hip != null)
            {
                s.Hip.Radius = OptNum(hip, "radius", 0);
                s.Hip.ProxyRadius = OptNum(hip, "proxy_radius", 0);
                s.Hip.Color = Field(hip, "color") as string ?? s.Hip.Color;
            }
            var hud = Field(m, "hud") as Dictionary<string, object>;
            if (hud != null) s.HudText = Field(hud, "text") as string ?? "";
            var objects = Field(m, "objects") as List<object>;
            if (objects == null) throw Protocol.Bad("scene.objects is an array");
            foreach (var e in objects)
            {
                var o = e as Dictionary<string, object>;
                if (o == null) throw Protocol.Bad("scene.objects[n] is a map");
                var obj = Object(o, s.Warnings);
                if (obj != null) s.Objects.Add(obj);
            }
            var overlays = Field(m, "overlays") as List<object>;
            if (overlays != null)
                foreach (var e in overlays)
                {
                    var o = e as Dictionary<string, object>;
                    if (o != null) s.Overlays.Add(Overlay(o));
                }
            return s;
        }

        static SceneObject Object(Dictionary<string, object> o, List<string> warnings)
        {
            var obj = new SceneObject { Id = Field(o, "id") as string ?? "" };
            var shape = Field(o, "shape") as Dictionary<string, object>;
            if (shape == null || !(Field(shape, "type") is string)) { warnings.Add("object '" + obj.Id + "' has no shape: skipped"); return null; }
            obj.Shape = new Shape { Type = (string)shape["type"], Radius = OptNum(shape, "radius", 0), Height = OptNum(shape, "height", 0) };
            var size = Field(shape, "size") as List<object>;
            if (size != null)
            {
                obj.Shape.Size = new double[size.Count];
                for (int i = 0; i < size.Count; i++) obj.Shape.Size[i] = Protocol.AsNum(size[i], "shape.size");
            }
            switch (obj.Shape.Type)
            {
                case "sphere": case "box": case "cylinder": case "cone": case "plane": case "hemisphere": break;
                case "mesh":
                    string why = Mesh(shape, obj.Shape);
                    if (why != null) { warnings.Add("mesh '" + obj.Id + "' is invalid (" + why + "): skipped"); return null; }
                    break;
                default: warnings.Add("object '" + obj.Id + "' has an unknown shape '" + obj.Shape.Type + "': skipped"); return null;
            }
            var pose = Field(o, "pose") as Dictionary<string, object>;
            if (pose != null)
            {
                obj.Pos = OptVec(pose, "pos", obj.Pos);
                if (Field(pose, "quat") != null) obj.Rot = Protocol.UnitQuat(pose["quat"], "pose.quat");
            }
            var mat = Field(o, "material") as Dictionary<string, object>;
            if (mat != null)
            {
                obj.Material.Color = Field(mat, "color") as string ?? obj.Material.Color;
                obj.Material.Opacity = OptNum(mat, "opacity", 1);
                obj.Material.StiffnessNPerM = OptNum(mat, "stiffness_n_per_m", 0);
                obj.Material.StaticFriction = OptNum(mat, "static_friction", 0);
                obj.Material.DynamicFriction = OptNum(mat, "dynamic_friction", 0);
                var skin = Field(mat, "skin") as Dictionary<string, object>;
                if (skin != null)
                {
                    obj.Material.SkinImage = Field(skin, "image") as string;
                    var tile = Field(skin, "tile") as List<object>;
                    if (tile != null && tile.Count == 2)
                        obj.Material.SkinTile = new[] { Protocol.AsNum(tile[0], "skin.tile"), Protocol.AsNum(tile[1], "skin.tile") };
                }
            }
            obj.Haptic = !(Field(o, "haptic") is bool) || (bool)o["haptic"];
            obj.Visible = !(Field(o, "visible") is bool) || (bool)o["visible"];
            return obj;
        }

        static string Mesh(Dictionary<string, object> shape, Shape into)
        {
            var vs = Field(shape, "vertices") as List<object>;
            var fs = Field(shape, "faces") as List<object>;
            if (vs == null || fs == null) return "no vertices or faces";
            if (vs.Count > MaxMeshVertices || fs.Count > MaxMeshFaces) return "too many vertices or faces";
            try
            {
                foreach (var v in vs) into.Vertices.Add(Protocol.Vec(v, "vertex"));
                foreach (var f in fs)
                {
                    var a = f as List<object>;
                    if (a == null || a.Count != 3) return "a face is not [i, j, k]";
                    var tri = new int[3];
                    for (int k = 0; k < 3; k++)
                    {
                        long i = Protocol.AsInt(a[k], "face index", 0);
                        if (i >= vs.Count) return "a face index is beyond the vertices";
                        tri[k] = (int)i;
                    }
                    into.Faces.Add(tri);
                }
            }
            catch (ProtocolException e) { return e.Message; }
            return null;
        }

        static Overlay Overlay(Dictionary<string, object> o)
        {
            var ov = new Overlay
            {
                Id = Field(o, "id") as string ?? "", Kind = Field(o, "kind") as string ?? "",
                Visible = !(Field(o, "visible") is bool) || (bool)o["visible"],
                Color = Field(o, "color") as string ?? "#ffffff", Text = Field(o, "text") as string ?? "",
            };
            ov.Centre = OptVec(o, "centre", ov.Centre);
            ov.Pos = OptVec(o, "pos", ov.Pos);
            ov.Radius = OptNum(o, "radius", 0);
            ov.FromDeg = OptNum(o, "from_deg", ov.FromDeg);
            ov.ToDeg = OptNum(o, "to_deg", ov.ToDeg);
            ov.MinorDeg = OptNum(o, "minor_deg", ov.MinorDeg);
            ov.MajorDeg = OptNum(o, "major_deg", ov.MajorDeg);
            ov.Size = OptNum(o, "size", ov.Size);
            return ov;
        }

        static object Field(Dictionary<string, object> m, string key) { return Protocol.Field(m, key); }

        static double OptNum(Dictionary<string, object> m, string key, double fallback)
        {
            var v = Field(m, key);
            return v == null ? fallback : Protocol.AsNum(v, key);
        }

        static Vec3 OptVec(Dictionary<string, object> m, string key, Vec3 fallback)
        {
            var v = Field(m, key);
            return v == null ? fallback : Protocol.Vec(v, key);
        }
    }
}
