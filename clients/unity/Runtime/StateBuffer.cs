// Smooth motion between 60 Hz state frames: snapshots keyed by server time, drawn a fixed delay
// behind the newest estimate of the server's clock, interpolated between the two snapshots
// around that time, and extrapolated at most `MaxExtrapolationS` past the newest (then held).
// Pure: the caller passes its own clock, so tests drive it.
using System;
using System.Collections.Generic;

namespace Viestac.Client
{
    public sealed class InterpolatedState
    {
        public double ServerT;
        public Vec3 Hip, Proxy;
        public readonly Dictionary<string, ObjectPose> Objects = new Dictionary<string, ObjectPose>();
        /// <summary>True when the render time lay beyond the newest snapshot.</summary>
        public bool Extrapolated;
    }

    public sealed class StateBuffer
    {
        sealed class Snapshot
        {
            public double T;
            public Vec3 Hip, Proxy;
            public readonly List<ObjectPose> Objects = new List<ObjectPose>();
        }

        readonly Snapshot[] _ring;
        int _count, _head; // _head: index of the newest
        double _offset = double.NegativeInfinity; // server time − local time, from the least delayed frame
        double _offsetAtS;

        /// <summary>How far behind the server's clock to draw (two to three frames at 60 Hz).</summary>
        public double DelayS = 0.05;
        public double MaxExtrapolationS = 0.1;
        /// <summary>The clock offset estimate forgets old minima slowly (clock drift, route changes).</summary>
        public double OffsetDecayPerS = 0.001;

        public StateBuffer(int capacity = 32)
        {
            _ring = new Snapshot[capacity];
            for (int i = 0; i < capacity; i++) _ring[i] = new Snapshot();
        }

        public int Count { get { return _count; } }

        public void Clear() { _count = 0; _offset = double.NegativeInfinity; }

        /// <summary>Adds a frame received at `localS` (the caller's clock, seconds). Frames out of order are dropped.</summary>
        public void Add(StateFrame s, double localS)
        {
            if (_count > 0 && s.T <= _ring[_head].T) return;
            // A frame that arrived with less delay than the estimate so far raises it at once;
            // otherwise it decays towards the recent frames.
            double candidate = s.T - localS;
            double aged = _offset - OffsetDecayPerS * Math.Max(0, localS - _offsetAtS);
            _offset = Math.Max(candidate, aged);
            _offsetAtS = localS;
            _head = (_head + 1) % _ring.Length;
            var snap = _ring[_head];
            snap.T = s.T; snap.Hip = s.Hip; snap.Proxy = s.Proxy;
            snap.Objects.Clear();
            snap.Objects.AddRange(s.Objects);
            if (_count < _ring.Length) _count++;
        }

        /// <summary>The server time this buffer draws at local time `localS`.</summary>
        public double RenderTime(double localS) { return localS + _offset - DelayS; }

        Snapshot At(int back) { return _ring[((_head - back) % _ring.Length + _ring.Length) % _ring.Length]; }

        /// <summary>Fills `into` for local time `localS`; false while empty.</summary>
        public bool Sample(double localS, InterpolatedState into)
        {
            if (_count == 0) return false;
            double t = RenderTime(localS);
            var newest = At(0);
            Snapshot a, b;
            if (t >= newest.T || _count == 1)
            {
                if (_count == 1) { Fill(into, newest, newest, 0); into.ServerT = newest.T; into.Extrapolated = t > newest.T; return true; }
                a = At(1); b = newest;
                double past = Math.Min(t - newest.T, MaxExtrapolationS);
                double f = (newest.T - a.T) > 0 ? 1 + past / (newest.T - a.T) : 1;
                Fill(into, a, b, f);
                into.ServerT = newest.T + past;
                into.Extrapolated = true;
                return true;
            }
            int i = 0;
            while (i + 1 < _count && At(i + 1).T > t) i++;
            b = At(i);
            a = i + 1 < _count ? At(i + 1) : b;
            double span = b.T - a.T;
            double frac = span > 0 ? Math.Max(0, (t - a.T) / span) : 1;
            Fill(into, a, b, frac);
            into.ServerT = span > 0 ? a.T + frac * span : b.T;
            into.Extrapolated = false;
            return true;
        }

        static void Fill(InterpolatedState into, Snapshot a, Snapshot b, double f)
        {
            into.Hip = Vec3.Lerp(a.Hip, b.Hip, f);
            into.Proxy = Vec3.Lerp(a.Proxy, b.Proxy, f);
            into.Objects.Clear();
            foreach (var pb in b.Objects)
            {
                var pose = pb;
                foreach (var pa in a.Objects)
                    if (pa.Id == pb.Id)
                    {
                        pose.Pos = Vec3.Lerp(pa.Pos, pb.Pos, f);
                        // beyond the newest the rotation holds: extrapolating quaternions overshoots badly
                        pose.Rot = Quat.Nlerp(pa.Rot, pb.Rot, Math.Min(1, f));
                        break;
                    }
                into.Objects[pb.Id] = pose;
            }
        }
    }
}
