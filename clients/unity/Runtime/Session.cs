// A connection to a ViESTac server that survives restarts: hello with role and token, decode on
// the receive thread, hand every message to the main thread through Drain() (or a
// SynchronizationContext), send the latest tracker sample and every input, reconnect with backoff.
using System;
using System.Collections.Generic;
using System.Diagnostics;
using System.Threading;
using System.Threading.Tasks;

namespace Viestac.Client
{
    public enum ConnectionStatus { Idle, Connecting, Connected, Reconnecting, Refused, Closed }

    public sealed class SessionOptions
    {
        /// <summary>ws://HOST:PORT/ws (wss:// for TLS).</summary>
        public Uri Url;
        /// <summary>The access token (docs/security.md); travels in hello.token only, never in the URL.</summary>
        public string Token;
        public string Role = Roles.Participant;
        public string ClientName = "viestac-unity/0.1";
        /// <summary>Reconnect after a drop (never after `unauthorized` or `unsupported_version`).</summary>
        public bool Reconnect = true;
        public Backoff Backoff = new Backoff();
        /// <summary>No frame for this long (states come at 60 Hz) means the connection is dead: reconnect.</summary>
        public double ReceiveTimeoutS = 5;
        public TimeSpan KeepAlive = TimeSpan.FromSeconds(5);
        /// <summary>Non-null: messages are dispatched on this context (Unity's main thread context)
        /// instead of waiting for Drain().</summary>
        public SynchronizationContext Context;
        /// <summary>Messages waiting undrained beyond this log a warning (120 = 2 s of states).</summary>
        public int WarnQueueLength = 120;
        /// <summary>Beyond this the oldest states are dropped (counted in DroppedStates).</summary>
        public int MaxQueueLength = 600;
        public Func<ITransport> TransportFactory;
        public Action<string> Log = Console.Error.WriteLine;
        /// <summary>Record each state frame's decode time (msgpack read + typed parse) for DecodeTimesUs().</summary>
        public bool MeasureDecode;
    }

    public sealed class ViestacSession : IDisposable
    {
        public event Action<Welcome> Welcomed;
        public event Action<SceneMessage> SceneReceived;
        /// <summary>The frame is pooled: read it inside the handler (StateBuffer.Add copies what it needs).</summary>
        public event Action<StateFrame> StateReceived;
        public event Action<ErrorMessage> ErrorReceived;
        public event Action<Health> HealthReceived;
        public event Action<Lease> LeaseReceived;
        /// <summary>What the study asks of this participant connection's session now (v1.5).</summary>
        public event Action<Ask> AskReceived;
        public event Action<ConnectionStatus, string> StatusChanged;

        public ConnectionStatus Status { get; private set; }
        public Welcome Welcome { get; private set; }
        public SceneMessage Scene { get; private set; }
        public long StatesReceived { get { return Interlocked.Read(ref _states); } }
        public long DroppedStates { get { return Interlocked.Read(ref _dropped); } }
        public long ProtocolErrors { get { return Interlocked.Read(ref _protocolErrors); } }
        public int Connections { get { return _connections; } }

        readonly SessionOptions _o;
        readonly CancellationTokenSource _stop = new CancellationTokenSource();
        readonly Stopwatch _clock = Stopwatch.StartNew();

        struct Inbound { public ServerMessage Message; public ConnectionStatus Status; public string Reason; }
        readonly Queue<Inbound> _inbox = new Queue<Inbound>(256);
        readonly Stack<StateFrame> _statePool = new Stack<StateFrame>();
        long _states, _dropped, _protocolErrors;
        int _connections, _dispatchPosted;
        double _lastDrainS, _lastWarnS = -1e9;
        readonly SendOrPostCallback _drainCallback;
        readonly double[] _decodeUs = new double[8192];
        int _decodeCount;

        // sending: the newest tracker sample wins (the server keeps only the latest), inputs queue
        readonly object _sendLock = new object();
        readonly SemaphoreSlim _sendSignal = new SemaphoreSlim(0);
        readonly Queue<object[]> _inputs = new Queue<object[]>();
        bool _trackerPending;
        // the sample waiting to be sent, and its points list, reused: sending allocates nothing
        readonly Tracker _tracker = new Tracker();
        readonly List<PointPos> _trackerPoints = new List<PointPos>();
        long _seq;
        Task _run;

        public ViestacSession(SessionOptions options)
        {
            if (options.Url == null) throw new ArgumentException("SessionOptions.Url is required");
            _o = options;
            if (_o.TransportFactory == null) _o.TransportFactory = () => new ClientWebSocketTransport(_o.KeepAlive);
            _drainCallback = _ => { Interlocked.Exchange(ref _dispatchPosted, 0); Drain(); };
        }

        double Now { get { return _clock.Elapsed.TotalSeconds; } }

        /// <summary>The session's clock (seconds, monotonic): StateFrame.ReceivedS is on it, so
        /// StateBuffer.Add(frame, frame.ReceivedS) and Sample(session.NowS, ...) match.</summary>
        public double NowS { get { return Now; } }

        public void Start()
        {
            if (_run != null) return;
            _lastDrainS = Now;
            _run = Task.Run(RunAsync);
        }

        // ---- main thread ----------------------------------------------------------------

        /// <summary>Dispatches every waiting message on the calling thread: call it once per
        /// frame from a MonoBehaviour's Update. Returns how many were dispatched.</summary>
        public int Drain()
        {
            _lastDrainS = Now;
            int n = 0;
            while (true)
            {
                Inbound item;
                lock (_inbox)
                {
                    if (_inbox.Count == 0) break;
                    item = _inbox.Dequeue();
                }
                Dispatch(item);
                n++;
            }
            return n;
        }

        /// <summary>Messages received and not yet dispatched.</summary>
        public int Pending { get { lock (_inbox) return _inbox.Count; } }

        void Dispatch(Inbound item)
        {
            var m = item.Message;
            if (m == null)
            {
                Status = item.Status;
                var h0 = StatusChanged; if (h0 != null) h0(item.Status, item.Reason);
                return;
            }
            switch (m.Type)
            {
                case MessageType.State:
                    var s = (StateFrame)m;
                    try { var h = StateReceived; if (h != null) h(s); }
                    finally { lock (_statePool) _statePool.Push(s); }
                    break;
                case MessageType.Welcome:
                    Welcome = (Welcome)m;
                    Status = ConnectionStatus.Connected;
                    var hw = Welcomed; if (hw != null) hw(Welcome);
                    var hs = StatusChanged; if (hs != null) hs(Status, "welcome");
                    break;
                case MessageType.Scene: Scene = (SceneMessage)m; var hsc = SceneReceived; if (hsc != null) hsc(Scene); break;
                case MessageType.Error: var he = ErrorReceived; if (he != null) he((ErrorMessage)m); break;
                case MessageType.Health: var hh = HealthReceived; if (hh != null) hh((Health)m); break;
                case MessageType.Lease: var hl = LeaseReceived; if (hl != null) hl((Lease)m); break;
                case MessageType.Ask: var ha = AskReceived; if (ha != null) ha((Ask)m); break;
            }
        }

        // ---- sending (any thread) -------------------------------------------------------

        /// <summary>Sends the HIP's pose (scene frame); only the newest sample waiting is sent (one
        /// sample carries every point of an instant: use SendTrackerPoints for a hand).
        /// `tMs` defaults to this machine's epoch milliseconds. Throws ProtocolException
        /// (`out_of_range` outside the ±10 workspace, `bad_message`, `non_finite`) as the server would.</summary>
        public void SendTracker(Vec3 pos, Quat? quat = null, double tMs = double.NaN)
        {
            SendSample(null, pos, quat, null, null, tMs);
        }

        /// <summary>A whole v1.4 sample (`Seq` is ignored: the session numbers its samples; `TMs`
        /// NaN means now). Checked as the server would; the sample is copied, so it may be reused.</summary>
        public void SendTracker(Tracker sample)
        {
            SendSample(sample.Point, sample.Pos, sample.Quat, sample.Points, sample.TtlMs, sample.TMs);
        }

        /// <summary>One named tracked point (TrackedPoints), e.g. "right.thumb.tip"; `ttlMs` (1..10000)
        /// makes the server call this source lost when no newer sample came by then. Returns false
        /// (and sends nothing) for a point other than the HIP when the server is older than v1.4,
        /// which would take any sample for the HIP.</summary>
        public bool SendTrackerPoint(string point, Vec3 pos, Quat? quat = null, double? ttlMs = null)
        {
            if (!TrackedPoints.IsPointName(point)) throw new ArgumentException("not a tracked point name: " + point);
            bool primary = point == TrackedPoints.Primary;
            if (!primary && !ServerHasPoints) return false;
            SendSample(primary ? null : point, pos, quat, null, ServerHasPoints ? ttlMs : null, double.NaN);
            return true;
        }

        /// <summary>Several points of one instant in one sample (a hand: every joint the tracker
        /// reports, see TrackedPoints): the HIP (`right.index.tip`) when listed, else the first,
        /// goes in `pos` with `quat`, the others in `points`. Returns false when nothing was sent:
        /// an empty list, or a server older than v1.4 and no HIP in the list (with a v1.3 server only
        /// the HIP is sent). No allocation: pass the same list every frame.</summary>
        public bool SendTrackerPoints(IList<PointPos> points, Quat? quat = null, double? ttlMs = null, double tMs = double.NaN)
        {
            if (points == null || points.Count == 0) return false;
            int main = 0;
            for (int i = 0; i < points.Count; i++) if (points[i].Name == TrackedPoints.Primary) { main = i; break; }
            bool v14 = ServerHasPoints;
            if (!v14 && points[main].Name != TrackedPoints.Primary) return false;
            ClientChecks.CheckTrackerV14(null, points, ttlMs); // names, workspace, duplicates, ttl
            var p = points[main];
            lock (_sendLock)
            {
                _trackerPoints.Clear();
                if (v14) for (int i = 0; i < points.Count; i++) if (i != main) _trackerPoints.Add(points[i]);
                SendSampleLocked(p.Name == TrackedPoints.Primary ? null : p.Name, p.Pos, quat,
                                 _trackerPoints.Count > 0 ? _trackerPoints : null, v14 ? ttlMs : null, tMs);
            }
            _sendSignal.Release();
            return true;
        }

        /// <summary>Whether the server takes `point`, `points` and `ttl` (protocol v1.4); true until
        /// the welcome says otherwise.</summary>
        public bool ServerHasPoints { get { var w = Welcome; return w == null || w.Minor >= 4; } }

        void SendSample(string point, Vec3 pos, Quat? quat, List<PointPos> points, double? ttlMs, double tMs)
        {
            // refused here with the server's code rather than answered with an error frame later
            ClientChecks.CheckTracker(0, double.IsNaN(tMs) ? 0 : tMs, pos, quat);
            ClientChecks.CheckTrackerV14(point, points, ttlMs);
            lock (_sendLock)
            {
                _trackerPoints.Clear();
                if (points != null) _trackerPoints.AddRange(points);
                SendSampleLocked(point, pos, quat, points != null ? _trackerPoints : null, ttlMs, tMs);
            }
            _sendSignal.Release();
        }

        void SendSampleLocked(string point, Vec3 pos, Quat? quat, List<PointPos> points, double? ttlMs, double tMs)
        {
            _tracker.Pos = pos; _tracker.Quat = quat; _tracker.Point = point; _tracker.Points = points; _tracker.TtlMs = ttlMs;
            _tracker.TMs = double.IsNaN(tMs) ? (DateTime.UtcNow - Epoch).TotalMilliseconds : tMs;
            _trackerPending = true;
        }

        /// <summary>A key or command (`input`); `value` null, a number, a bool or a string (≤ 200
        /// characters). Throws ProtocolException for what the server would refuse.</summary>
        public void SendInput(string key, string action, object value = null)
        {
            ClientChecks.CheckInput(key, action, value);
            lock (_sendLock) _inputs.Enqueue(new[] { key, action, value });
            _sendSignal.Release();
        }

        static readonly DateTime Epoch = new DateTime(1970, 1, 1, 0, 0, 0, DateTimeKind.Utc);

        async Task SendLoopAsync(ITransport t, CancellationToken ct)
        {
            var w = new MsgPackWriter(256);
            while (!ct.IsCancellationRequested)
            {
                await _sendSignal.WaitAsync(ct).ConfigureAwait(false);
                while (true)
                {
                    w.Clear();
                    lock (_sendLock)
                    {
                        if (_inputs.Count > 0)
                        {
                            var i = _inputs.Dequeue();
                            Protocol.WriteInput(w, (string)i[0], (string)i[1], i[2]);
                        }
                        else if (_trackerPending)
                        {
                            _trackerPending = false;
                            _tracker.Seq = _seq++;
                            Protocol.WriteTracker(w, _tracker);
                        }
                        else break;
                    }
                    await t.SendAsync(w.Segment, ct).ConfigureAwait(false);
                }
            }
        }

        // ---- receive thread -------------------------------------------------------------

        void Post(Inbound item)
        {
            int count;
            lock (_inbox)
            {
                _inbox.Enqueue(item);
                if (_inbox.Count > _o.MaxQueueLength) DropOldestStates();
                count = _inbox.Count;
            }
            var ctx = _o.Context;
            if (ctx != null)
            {
                if (Interlocked.Exchange(ref _dispatchPosted, 1) == 0) ctx.Post(_drainCallback, null);
                return;
            }
            double now = Now;
            if (count > _o.WarnQueueLength && now - _lastWarnS > 5)
            {
                _lastWarnS = now;
                _o.Log(string.Format("ViestacSession: {0} messages wait undrained (Drain() last called {1:0.0} s ago). " +
                    "Call session.Drain() every frame from a MonoBehaviour's Update, or set SessionOptions.Context " +
                    "to SynchronizationContext.Current on the main thread.", count, now - _lastDrainS));
            }
        }

        /// <summary>Far behind (nobody drains): drop the oldest states down to 3/4 of the cap,
        /// keeping every other message and the order. Under the inbox lock.</summary>
        void DropOldestStates()
        {
            int excess = _inbox.Count - _o.MaxQueueLength * 3 / 4;
            for (int n = _inbox.Count; n > 0; n--)
            {
                var item = _inbox.Dequeue();
                var state = item.Message as StateFrame;
                if (state != null && excess > 0)
                {
                    excess--;
                    lock (_statePool) _statePool.Push(state);
                    Interlocked.Increment(ref _dropped);
                }
                else _inbox.Enqueue(item);
            }
        }

        void PostStatus(ConnectionStatus status, string reason)
        {
            Post(new Inbound { Status = status, Reason = reason });
        }

        StateFrame RentState()
        {
            lock (_statePool) return _statePool.Count > 0 ? _statePool.Pop() : new StateFrame();
        }

        async Task RunAsync()
        {
            var ct = _stop.Token;
            var reader = new MsgPackReader();
            var buffer = new FrameBuffer();
            var hello = new MsgPackWriter(512);
            while (!ct.IsCancellationRequested)
            {
                bool refused = false;
                string why = "";
                PostStatus(_connections == 0 ? ConnectionStatus.Connecting : ConnectionStatus.Reconnecting, "");
                var t = _o.TransportFactory();
                var connCts = CancellationTokenSource.CreateLinkedTokenSource(ct);
                Task sender = null;
                try
                {
                    await t.ConnectAsync(_o.Url, Protocol.MsgPackSubprotocol, ct).ConfigureAwait(false);
                    Interlocked.Increment(ref _connections);
                    lock (_sendLock) _trackerPending = false; // a sample from before the drop is stale now
                    hello.Clear();
                    Protocol.WriteHello(hello, _o.Role, _o.ClientName, _o.Token);
                    await t.SendAsync(hello.Segment, ct).ConfigureAwait(false);
                    sender = SendLoopAsync(t, connCts.Token);
                    while (!ct.IsCancellationRequested)
                    {
                        var receive = t.ReceiveAsync(buffer, connCts.Token);
                        var first = await Task.WhenAny(receive, Task.Delay(TimeSpan.FromSeconds(_o.ReceiveTimeoutS), ct)).ConfigureAwait(false);
                        if (first != receive) { why = "no frame for " + _o.ReceiveTimeoutS + " s"; break; }
                        int n = await receive.ConfigureAwait(false);
                        if (n < 0) { if (!refused) why = "closed by the server (" + t.CloseCode + " " + t.CloseReason + ")"; break; }
                        ServerMessage m;
                        long started = Stopwatch.GetTimestamp();
                        try
                        {
                            var pooled = RentState();
                            m = Protocol.Decode(reader, buffer.Bytes, 0, n, pooled);
                            if (!(m is StateFrame)) lock (_statePool) _statePool.Push(pooled);
                        }
                        catch (ProtocolException e)
                        {
                            Interlocked.Increment(ref _protocolErrors);
                            _o.Log("ViestacSession: refused a server frame (" + e.Code + "): " + e.Message);
                            continue;
                        }
                        if (m == null) continue; // a message type this client does not know
                        if (m is StateFrame)
                        {
                            ((StateFrame)m).ReceivedS = Now;
                            Interlocked.Increment(ref _states);
                            if (_o.MeasureDecode)
                                lock (_decodeUs) _decodeUs[_decodeCount++ % _decodeUs.Length] = (Stopwatch.GetTimestamp() - started) * 1e6 / Stopwatch.Frequency;
                        }
                        if (m is Welcome) _o.Backoff.Reset();
                        var sc = m as SceneMessage;
                        if (sc != null && !sc.HashVerified)
                            _o.Log("ViestacSession: scene '" + sc.Scene.Name + "' does not hash to " + sc.Hash + " (docs/protocol.md \"Scene hash\"): drawn anyway");
                        var err = m as ErrorMessage;
                        if (err != null && (err.Code == "unauthorized" || err.Code == "unsupported_version"))
                        {
                            refused = true;
                            why = err.Code + ": " + err.Message;
                        }
                        Post(new Inbound { Message = m });
                    }
                }
                catch (OperationCanceledException) when (ct.IsCancellationRequested) { break; }
                catch (Exception e) when (!(e is OutOfMemoryException))
                {
                    why = e.GetType().Name + ": " + e.Message;
                }
                finally
                {
                    connCts.Cancel();
                    t.Dispose();
                    if (sender != null) try { await sender.ConfigureAwait(false); } catch (Exception) { /* ended with the connection */ }
                    connCts.Dispose();
                }
                if (ct.IsCancellationRequested) break;
                if (refused || !_o.Reconnect)
                {
                    PostStatus(refused ? ConnectionStatus.Refused : ConnectionStatus.Closed, why);
                    return;
                }
                double delay = _o.Backoff.NextDelayS();
                PostStatus(ConnectionStatus.Reconnecting, why + "; again in " + delay.ToString("0.00") + " s");
                try { await Task.Delay(TimeSpan.FromSeconds(delay), ct).ConfigureAwait(false); }
                catch (OperationCanceledException) { break; }
            }
            PostStatus(ConnectionStatus.Closed, "closed");
        }

        /// <summary>The last (up to 8192) state decode times in µs, with MeasureDecode set.</summary>
        public double[] DecodeTimesUs()
        {
            lock (_decodeUs)
            {
                int n = Math.Min(_decodeCount, _decodeUs.Length);
                var copy = new double[n];
                Array.Copy(_decodeUs, copy, n);
                return copy;
            }
        }

        public void ResetDecodeTimes() { lock (_decodeUs) _decodeCount = 0; }

        public void Dispose()
        {
            _stop.Cancel();
            try { if (_run != null) _run.Wait(2000); } catch (AggregateException) { /* cancelled */ }
        }
    }
}
