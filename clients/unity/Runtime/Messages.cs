// The protocol's messages as typed data (docs/protocol.md "Client → server", "Server → client").
using System;
using System.Collections.Generic;

namespace Viestac.Client
{
    /// <summary>A position in the scene frame (x toward the viewer, y right, z up), scene units.</summary>
    public struct Vec3
    {
        public double X, Y, Z;
        public Vec3(double x, double y, double z) { X = x; Y = y; Z = z; }
        public static Vec3 Lerp(Vec3 a, Vec3 b, double t) { return new Vec3(a.X + (b.X - a.X) * t, a.Y + (b.Y - a.Y) * t, a.Z + (b.Z - a.Z) * t); }
        public override string ToString() { return string.Format(System.Globalization.CultureInfo.InvariantCulture, "[{0:0.####}, {1:0.####}, {2:0.####}]", X, Y, Z); }
    }

    /// <summary>A rotation in the scene frame, [w, x, y, z] as on the wire.</summary>
    public struct Quat
    {
        public double W, X, Y, Z;
        public Quat(double w, double x, double y, double z) { W = w; X = x; Y = y; Z = z; }
        public static readonly Quat Identity = new Quat(1, 0, 0, 0);
        public double Norm { get { return Math.Sqrt(W * W + X * X + Y * Y + Z * Z); } }

        /// <summary>Normalised linear interpolation along the shorter arc (frames are ~17 ms apart).</summary>
        public static Quat Nlerp(Quat a, Quat b, double t)
        {
            double dot = a.W * b.W + a.X * b.X + a.Y * b.Y + a.Z * b.Z;
            double s = dot < 0 ? -1 : 1;
            var q = new Quat(a.W + (s * b.W - a.W) * t, a.X + (s * b.X - a.X) * t, a.Y + (s * b.Y - a.Y) * t, a.Z + (s * b.Z - a.Z) * t);
            double n = q.Norm;
            return n > 0 ? new Quat(q.W / n, q.X / n, q.Y / n, q.Z / n) : a;
        }
    }

    public enum MessageType { Welcome, Scene, State, Error, Health, Lease, Ask }

    public abstract class ServerMessage
    {
        public abstract MessageType Type { get; }
    }

    public sealed class Identity
    {
        public string TokenId, Role, Site, Session;
    }

    public sealed class Welcome : ServerMessage
    {
        public override MessageType Type { get { return MessageType.Welcome; } }
        public long V, ClientId, TickHz;
        /// <summary>-1 for a v1.0 server (no `minor`).</summary>
        public long Minor = -1;
        public string Role, Server, Format;
        public double StateHz;
        public Identity Identity;
    }

    public sealed class SceneMessage : ServerMessage
    {
        public override MessageType Type { get { return MessageType.Scene; } }
        public long V;
        public string Hash;
        public Scene Scene;
        /// <summary>The decoded scene map, as the hash is computed over it.</summary>
        public Dictionary<string, object> Raw;
        /// <summary>Whether `Hash` is the hash of the scene received (SceneHash.Of(Raw)).</summary>
        public bool HashVerified;
    }

    public struct Contact
    {
        public string ObjectId;
        public Vec3 Normal;
        public double Depth;
    }

    public struct ObjectPose
    {
        public string Id;
        public Vec3 Pos;
        public Quat Rot;
    }

    /// <summary>A device-independent cue: its kind and numeric fields (`server/core/cues.py`; clients skip unknown kinds).</summary>
    public sealed class Cue
    {
        public string Kind;
        public readonly Dictionary<string, double> Fields = new Dictionary<string, double>();
        public double Get(string field, double fallback = double.NaN)
        {
            double v;
            return Fields.TryGetValue(field, out v) ? v : fallback;
        }
    }

    /// <summary>One tool of `state.tools` (v1.4): a tracked point and its god-object.</summary>
    public struct ToolState
    {
        /// <summary>The point that drives it (TrackedPoints), e.g. "right.thumb.tip".</summary>
        public string Name;
        public Vec3 Hip, Proxy;
        public bool Contact;
        /// <summary>Its tracker source stopped (ttl passed): the tool is home and out of contact.</summary>
        public bool Lost;
    }

    /// <summary>A tracker source as `state.driver` and `state.tracking.lost` name it: a /ws
    /// client's welcome id, or a UDP bridge ("udp:HOST:PORT").</summary>
    public struct TrackerSource
    {
        public long ClientId;
        /// <summary>Null for a /ws client.</summary>
        public string Bridge;
        public override string ToString() { return Bridge ?? ClientId.ToString(System.Globalization.CultureInfo.InvariantCulture); }
    }

    /// <summary>A named point and its position (scene frame): one entry of `tracker.points`.</summary>
    public struct PointPos
    {
        public string Name;
        public Vec3 Pos;
        public PointPos(string name, Vec3 pos) { Name = name; Pos = pos; }
    }

    /// <summary>A `tracker` sample (client → server). v1.4: `Point` names the point `Pos` is (null:
    /// the primary, right.index.tip), `Points` more points of the same instant (null: none sent;
    /// written in list order), `TtlMs` how long the sample is good for (null: until the next).</summary>
    public sealed class Tracker
    {
        public long Seq;
        public double TMs;
        public Vec3 Pos;
        public Quat? Quat;
        public string Point;
        public List<PointPos> Points;
        public double? TtlMs;
    }

    public struct Telemetry
    {
        public double PeriodP50Us, PeriodP99Us, PeriodMaxUs, TickCostP99Us;
        public long Overruns, Ticks;
        public bool Rt;
    }

    /// <summary>One `state` frame. Instances are pooled by the session: read them inside the
    /// handler (or copy), never keep a reference past it.</summary>
    public sealed class StateFrame : ServerMessage
    {
        public override MessageType Type { get { return MessageType.State; } }
        public long Frame, Tick;
        /// <summary>Server monotonic time of the tick, seconds.</summary>
        public double T;
        /// <summary>When the session received the frame, on its clock (ViestacSession.NowS).</summary>
        public double ReceivedS;
        public string SceneHash, Hud;
        public Vec3 Hip, Proxy, Force;
        public bool Contact;
        public readonly List<Contact> Contacts = new List<Contact>();
        public readonly List<ObjectPose> Objects = new List<ObjectPose>();
        public readonly List<Cue> Cues = new List<Cue>();
        public readonly Dictionary<string, object> Values = new Dictionary<string, object>();
        public Telemetry Telemetry;
        public readonly Dictionary<string, bool> Visible = new Dictionary<string, bool>();
        public readonly List<Dictionary<string, object>> Events = new List<Dictionary<string, object>>();
        public readonly Dictionary<string, Vec3> Scales = new Dictionary<string, Vec3>();
        public readonly Dictionary<string, double> Stiffness = new Dictionary<string, double>();
        public readonly Dictionary<string, bool> Haptic = new Dictionary<string, bool>();
        /// <summary>Whether a source drives the HIP (`driver` not null); then either DriverClientId
        /// (a /ws client's welcome id) or DriverBridge ("udp:HOST:PORT") names it.</summary>
        public bool HasDriver;
        public long DriverClientId, DriverSeq;
        public string DriverBridge;
        /// <summary>v1.4: every tool, primary first (empty from a v1.3 server: then Hip/Proxy/Contact are the only tool).</summary>
        public readonly List<ToolState> Tools = new List<ToolState>();
        /// <summary>v1.4: the latest tracked points that drive no tool (a hand's other joints).</summary>
        public readonly Dictionary<string, Vec3> Points = new Dictionary<string, Vec3>();
        /// <summary>v1.4: the tracker sources lost right now (`tracking.lost`).</summary>
        public readonly List<TrackerSource> TrackingLost = new List<TrackerSource>();
        /// <summary>v1.6: what a browser device's page plays now (`actuator`, only on a rig with one):
        /// [value 0..1, on_ms, off_ms, duration_ms, onset tick]. Read and checked; this client drives
        /// no actuator with it yet.</summary>
        public bool HasActuator;
        public readonly double[] Actuator = new double[5];

        readonly List<Cue> _cuePool = new List<Cue>();

        internal Cue RentCue()
        {
            Cue c;
            if (_cuePool.Count > 0) { c = _cuePool[_cuePool.Count - 1]; _cuePool.RemoveAt(_cuePool.Count - 1); c.Fields.Clear(); }
            else c = new Cue();
            return c;
        }

        internal void Reset()
        {
            Contacts.Clear(); Objects.Clear(); Values.Clear(); Visible.Clear(); Events.Clear();
            Scales.Clear(); Stiffness.Clear(); Haptic.Clear(); Tools.Clear(); Points.Clear(); TrackingLost.Clear();
            for (int i = 0; i < Cues.Count; i++) _cuePool.Add(Cues[i]); // AddRange would copy through a new array
            Cues.Clear();
            HasDriver = false; DriverClientId = 0; DriverBridge = null; DriverSeq = 0; Telemetry = default(Telemetry); Hud = ""; Contact = false;
            HasActuator = false;
        }

        /// <summary>Whether this client's own tracker drives the HIP (`driver[0]` is its welcome's client id).</summary>
        public bool DrivenBy(long clientId) { return HasDriver && DriverBridge == null && DriverClientId == clientId; }

        // the last box of each `values` entry: an unchanged number is not boxed again
        internal readonly Dictionary<string, object> ValueBoxes = new Dictionary<string, object>();

        public void CopyTo(StateFrame other)
        {
            other.Reset();
            other.Frame = Frame; other.Tick = Tick; other.T = T; other.ReceivedS = ReceivedS; other.SceneHash = SceneHash; other.Hud = Hud;
            other.Hip = Hip; other.Proxy = Proxy; other.Force = Force; other.Contact = Contact;
            other.Contacts.AddRange(Contacts); other.Objects.AddRange(Objects);
            foreach (var c in Cues) { var d = other.RentCue(); d.Kind = c.Kind; foreach (var kv in c.Fields) d.Fields[kv.Key] = kv.Value; other.Cues.Add(d); }
            foreach (var kv in Values) other.Values[kv.Key] = kv.Value;
            other.Telemetry = Telemetry;
            foreach (var kv in Visible) other.Visible[kv.Key] = kv.Value;
            other.Events.AddRange(Events);
            foreach (var kv in Scales) other.Scales[kv.Key] = kv.Value;
            foreach (var kv in Stiffness) other.Stiffness[kv.Key] = kv.Value;
            foreach (var kv in Haptic) other.Haptic[kv.Key] = kv.Value;
            other.Tools.AddRange(Tools); other.TrackingLost.AddRange(TrackingLost);
            foreach (var kv in Points) other.Points[kv.Key] = kv.Value;
            other.HasDriver = HasDriver; other.DriverClientId = DriverClientId; other.DriverBridge = DriverBridge; other.DriverSeq = DriverSeq;
            other.HasActuator = HasActuator; Array.Copy(Actuator, other.Actuator, Actuator.Length);
        }
    }

    public sealed class ErrorMessage : ServerMessage
    {
        public override MessageType Type { get { return MessageType.Error; } }
        public string Code, Message;
    }

    public struct HealthReason
    {
        public string Code, Message;
    }

    public sealed class Health : ServerMessage
    {
        public override MessageType Type { get { return MessageType.Health; } }
        public string Status;
        public readonly List<HealthReason> Reasons = new List<HealthReason>();
    }

    public sealed class LeaseParty
    {
        public string TokenId, Role, Site, Label;
        public long Position;
        public double Since, ExpiresAt;
    }

    public sealed class Lease : ServerMessage
    {
        public override MessageType Type { get { return MessageType.Lease; } }
        public LeaseParty Holder;
        public readonly List<LeaseParty> Queue = new List<LeaseParty>();
        public string Session;
        public double TtlS;
    }

    /// <summary>v1.5: what the study asks of this participant now (docs/protocol.md `ask`).</summary>
    public sealed class Ask : ServerMessage
    {
        public override MessageType Type { get { return MessageType.Ask; } }
        public string Session, Task, Instructions;
        public long? Seq;  // the running trial, or null
        public readonly List<Dictionary<string, object>> Questions = new List<Dictionary<string, object>>();
        public bool Speech, ContactSounds;
        /// <summary>v1.6: a participant-paced task's {state, done, total, feedback}, or null (docs/protocol.md).
        /// During a break (state "break") the participant continues with Answer(0, "pacing:continue", 1).</summary>
        public Dictionary<string, object> Pacing;
    }

    public static class Roles
    {
        public const string Participant = "participant", Operator = "operator", Observer = "observer";
    }

    public static class InputActions
    {
        public const string Down = "down", Up = "up", Press = "press";
    }
}
