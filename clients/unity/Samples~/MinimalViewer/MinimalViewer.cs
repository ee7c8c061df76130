// The README's minimal behaviour: connect, pump on the main thread, react to contact.
using UnityEngine;
using Viestac.Client;

public class MinimalViewer : MonoBehaviour
{
    public string url = "ws://127.0.0.1:8000/ws";
    public string token = "";          // from `viestac token create` (docs/security.md)
    public Transform hipMarker;        // any object: it follows the HIP

    ViestacSession session;

    void Start()
    {
        session = new ViestacSession(new SessionOptions { Url = new System.Uri(url), Token = token, Role = Roles.Observer, Log = Debug.LogWarning });
        session.SceneReceived += scene => Debug.Log("scene " + scene.Scene.Name + " with " + scene.Scene.Objects.Count + " objects");
        session.StateReceived += state =>
        {
            float x, y, z;
            Coordinates.ToUnity(state.Hip, out x, out y, out z);   // scene frame → Unity
            if (hipMarker != null) hipMarker.localPosition = new Vector3(x, y, z);
            if (state.Contact) Debug.Log("contact, force " + state.Force);
        };
        session.Start();
    }

    // Without this call no handler ever runs: messages wait (and a warning says so).
    void Update() { session.Drain(); }

    void OnDestroy() { session.Dispose(); }
}
