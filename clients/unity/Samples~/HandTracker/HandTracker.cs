// A scene viewer with the right index fingertip as the HIP: add ViestacSceneBehaviour and
// ViestacTrackerBehaviour and point the tracker at the fingertip's Transform (e.g. from the XR
// Hands package's joint of XRHandJointID.IndexTip).
using UnityEngine;
using Viestac.Client;
using Viestac.Unity;

public class HandTracker : MonoBehaviour
{
    public Transform indexTip;
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
    }
}
