using System;

namespace Viestac.Client
{
    /// <summary>Reconnect delays: exponential from `Initial` to `Max`, with ±`Jitter` so that many
    /// clients of a restarted server do not all come back in the same millisecond.</summary>
    public sealed class Backoff
    {
        public double InitialS = 0.25, MaxS = 8, Factor = 2, Jitter = 0.2;
        readonly Random _random;
        double _next;

        public Backoff(Random random = null) { _random = random ?? new Random(); _next = -1; }

        public double NextDelayS()
        {
            _next = _next < 0 ? InitialS : Math.Min(MaxS, _next * Factor);
            return _next * (1 + Jitter * (2 * _random.NextDouble() - 1));
        }

        /// <summary>After a connection that got its welcome.</summary>
        public void Reset() { _next = -1; }
    }
}
