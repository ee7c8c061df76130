// Thin adapter: sends a Transform (an XR hand joint, a controller, a mouse-driven object) as the
// HIP's tracker, in the scene frame of the viewer it belongs to.
using UnityEngine;
using Viestac.Client;

namespace Viestac.Unity
{
    public class ViestacTrackerBehaviour : MonoBehaviour
    {
        [Tooltip("The viewer whose session and scene root this tracker uses")] public ViestacSceneBehaviour viewer;
        [Tooltip("What to track; this GameObject's transform when empty")] public Transform target;
        [Tooltip("The tracked point's name (right.index.tip drives the HIP)")] public string point = TrackedPoints.Primary;
        public bool sendRotation = true;
        [Tooltip("Samples a second; the server keeps the newest, so more than the display rate only costs bandwidth")] public float rateHz = 90;

        float _next;

        void Update()
        {
            if (viewer == null || viewer.Session == null || viewer.Root == null) return;
            if (viewer.Session.Status != ConnectionStatus.Connected || Time.unscaledTime < _next) return;
            _next = Time.unscaledTime + 1f / Mathf.Max(1f, rateHz);
            var t = target != null ? target : transform;
            var local = viewer.Root.InverseTransformPoint(t.position);
            var rotation = Quaternion.Inverse(viewer.Root.rotation) * t.rotation;
            var pos = UnityConvert.ScenePosition(local);
            if (System.Math.Abs(pos.X) > Protocol.WorkspaceHalfExtent || System.Math.Abs(pos.Y) > Protocol.WorkspaceHalfExtent ||
                System.Math.Abs(pos.Z) > Protocol.WorkspaceHalfExtent) return; // outside the workspace: the server would refuse it
            viewer.Session.SendTrackerPoint(point, pos, sendRotation ? UnityConvert.SceneRotation(rotation) : (Quat?)null);
        }
    }
}
