using System;

namespace Viestac.Client
{
    /// <summary>Names of tracked points, one scheme for every tracker and client (server/core/points.py):
    /// `HAND.wrist`, `HAND.palm` or `HAND.FINGER.JOINT` after the WebXR Hand Input joints, e.g.
    /// `right.index.tip`. Protocol v1.3 carries one point on /ws, the HIP (`Primary`).</summary>
    public static class TrackedPoints
    {
        public const string Primary = "right.index.tip";
        static readonly string[] Hands = { "left", "right" };
        static readonly string[] Fingers = { "thumb", "index", "middle", "ring", "pinky" };
        static readonly string[] Joints = { "metacarpal", "proximal", "intermediate", "distal", "tip" };

        public static bool IsPointName(string name)
        {
            if (string.IsNullOrEmpty(name)) return false;
            var p = name.Split('.');
            if (Array.IndexOf(Hands, p[0]) < 0) return false;
            if (p.Length == 2) return p[1] == "wrist" || p[1] == "palm";
            if (p.Length != 3 || Array.IndexOf(Fingers, p[1]) < 0 || Array.IndexOf(Joints, p[2]) < 0) return false;
            return !(p[1] == "thumb" && p[2] == "intermediate");
        }

        /// <summary>The point name of a WebXR / OpenXR hand joint ("index-finger-tip" of the right hand → "right.index.tip"), or null.</summary>
        public static string FromWebXR(string handedness, string joint)
        {
            if (Array.IndexOf(Hands, handedness) < 0 || joint == null) return null;
            if (joint == "wrist") return handedness + ".wrist";
            foreach (var f in Fingers)
            {
                var prefix = f == "thumb" ? "thumb-" : f + "-finger-";
                if (!joint.StartsWith(prefix, StringComparison.Ordinal)) continue;
                var rest = joint.Substring(prefix.Length);
                if (rest.StartsWith("phalanx-", StringComparison.Ordinal)) rest = rest.Substring(8);
                var name = handedness + "." + f + "." + rest;
                return IsPointName(name) ? name : null;
            }
            return null;
        }
    }
}
