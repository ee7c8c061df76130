// A scene viewer driven by a tracked right hand: the index fingertip is the HIP, and every other
// joint given goes in the same sample (protocol v1.4 `points`), so the server can put a tool on
// the thumb too and draws the hand. Point `joints` at the XR Hands package's joint Transforms
// (e.g. XRHandJointID.IndexTip, ThumbTip, Wrist), each with its WebXR joint name.
using UnityEngine;
using Viestac.Client;
using Viestac.Unity;

public class HandTracker : MonoBehaviour
{
    [System.Serializable]
    public class Joint
    {
        [Tooltip("WebXR joint name, e.g. index-finger-tip, thumb-tip, wrist")] public string webxrName;
        public Transform target;
    }

    public Transform indexTip;
    public Joint[] joints = new Joint[0];
    public string token = "";

    void Awake()
    {
        var viewer = gameObject.AddComponent<ViestacSceneBehaviour>();
        viewer.token = token;
        viewer.role = Roles.Participant;
        var tracker = gameObject.AddComponent<ViestacTrackerBehaviour>();
        tracker.viewer = viewer;
        tracker.target = indexTip;
        tracker.point = TrackedPoints.FromWebXR("right", "index-finger-tip");
        foreach (var j in joints)
        {
            var name = TrackedPoints.FromWebXR("right", j.webxrName);
            if (name == null) { Debug.LogWarning("not a WebXR hand joint: " + j.webxrName); continue; }
            tracker.joints.Add(new TrackedJoint(name, j.target));
        }
        tracker.ttlMs = 100; // a joint the XR runtime stops tracking stops being sent: the server notices within 100 ms
    }
}
