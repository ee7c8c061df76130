// Thin adapter: sends Transforms (an XR hand's joints, a controller, a mouse-driven object) as
// tracked points, in the scene frame of the viewer it belongs to. All joints of a frame go in one
// `tracker` sample (protocol v1.4 `points`): they are of one instant, and the session sends only
// the newest sample waiting, so separate samples per joint would replace each other.
using System.Collections.Generic;
using UnityEngine;
using Viestac.Client;

namespace Viestac.Unity
{
    /// <summary>One joint to send: its point name (TrackedPoints, e.g. "right.thumb.tip") and its Transform.</summary>
    [System.Serializable]
    public class TrackedJoint
    {
        public string point;
        public Transform target;
        public TrackedJoint() { }
        public TrackedJoint(string point, Transform target) { this.point = point; this.target = target; }
    }

    public class ViestacTrackerBehaviour : MonoBehaviour
    {
        [Tooltip("The viewer whose session and scene root this tracker uses")] public ViestacSceneBehaviour viewer;
        [Tooltip("What to track; this GameObject's transform when empty (and no joints are given)")] public Transform target;
        [Tooltip("The tracked point's name (right.index.tip drives the HIP)")] public string point = TrackedPoints.Primary;
        [Tooltip("More joints sent in the same sample (a hand: every joint the XR tracker reports); when set, target is sent only if it is not null")]
        public List<TrackedJoint> joints = new List<TrackedJoint>();
        public bool sendRotation = true;
        [Tooltip("Samples a second; the server keeps the newest, so more than the display rate only costs bandwidth")] public float rateHz = 90;
        [Tooltip("ms a sample is good for (1..10000; 0: held until the next): the server calls this tracker lost when no newer sample came by then. Longer than your worst frame hitch")]
        public float ttlMs = 0;

        float _next;
        readonly List<PointPos> _points = new List<PointPos>(); // reused: no allocation per sample

        void Update()
        {
            if (viewer == null || viewer.Session == null || viewer.Root == null) return;
            if (viewer.Session.Status != ConnectionStatus.Connected || Time.unscaledTime < _next) return;
            _next = Time.unscaledTime + 1f / Mathf.Max(1f, rateHz);
            double? ttl = ttlMs > 0 ? System.Math.Max(ClientChecks.MinTtlMs, System.Math.Min(ClientChecks.MaxTtlMs, (double)ttlMs)) : (double?)null;

            var t = target != null ? target : (joints.Count == 0 ? transform : null);
            Quat? rotation = null;
            _points.Clear();
            if (t != null && Add(point, t) && sendRotation)
                rotation = UnityConvert.SceneRotation(Quaternion.Inverse(viewer.Root.rotation) * t.rotation);
            foreach (var j in joints) if (j != null && j.target != null) Add(j.point, j.target);
            if (_points.Count == 0) return;
            // the session puts the HIP (or the first point) in `pos`; the rotation belongs to `target`'s point
            if (rotation != null && !IsPos(_points[0].Name)) rotation = null;
            viewer.Session.SendTrackerPoints(_points, rotation, ttl);
        }

        bool IsPos(string name)
        {
            for (int i = 0; i < _points.Count; i++) if (_points[i].Name == TrackedPoints.Primary) return name == TrackedPoints.Primary;
            return true; // no HIP listed: the first point is `pos`
        }

        /// <summary>Adds a joint that is tracked now (its GameObject active) and inside the workspace.</summary>
        bool Add(string name, Transform joint)
        {
            if (!TrackedPoints.IsPointName(name) || !joint.gameObject.activeInHierarchy) return false;
            for (int i = 0; i < _points.Count; i++) if (_points[i].Name == name) return false;
            var pos = UnityConvert.ScenePosition(viewer.Root.InverseTransformPoint(joint.position));
            double h = Protocol.WorkspaceHalfExtent;
            if (System.Math.Abs(pos.X) > h || System.Math.Abs(pos.Y) > h || System.Math.Abs(pos.Z) > h) return false; // the server would refuse it
            _points.Add(new PointPos(name, pos));
            return true;
        }
    }
}
