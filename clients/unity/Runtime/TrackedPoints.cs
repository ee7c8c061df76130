using System;
using System.Collections.Generic;

namespace Viestac.Client
{
    /// <summary>Names of tracked points, one scheme for every tracker and client (server/core/points.py):
    /// `HAND.wrist`, `HAND.palm` or `HAND.FINGER.JOINT` after the WebXR Hand Input joints, e.g.
    /// `right.index.tip`. `Primary` is the HIP; protocol v1.4 carries any of them (`tracker.point`,
    /// `tracker.points`, `state.tools`, `state.points`).</summary>
    public static class TrackedPoints
    {
        public const string Primary = "right.index.tip";
        static readonly string[] Hands = { "left", "right" };
        static readonly string[] Fingers = { "thumb", "index", "middle", "ring", "pinky" };
        static readonly string[] Joints = { "metacarpal", "proximal", "intermediate", "distal", "tip" };

        /// <summary>Every point name, as server/core/points.py lists them: per hand (left, right)
        /// wrist, palm, then each finger from base to tip.</summary>
        public static readonly IList<string> All = Build();
        static readonly HashSet<string> Names = new HashSet<string>(All, StringComparer.Ordinal);

        static IList<string> Build()
        {
            var all = new List<string>();
            foreach (var hand in Hands)
            {
                all.Add(hand + ".wrist"); all.Add(hand + ".palm");
                foreach (var f in Fingers)
                    foreach (var j in Joints)
                        if (!(f == "thumb" && j == "intermediate")) all.Add(hand + "." + f + "." + j);
            }
            return all.AsReadOnly();
        }

        /// <summary>Whether `name` is a point name (no allocation: the state reader checks every key).</summary>
        public static bool IsPointName(string name) { return name != null && Names.Contains(name); }

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
