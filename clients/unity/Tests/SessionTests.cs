// The session against an in-memory transport: the main-thread pump, the undrained warning, the
// SynchronizationContext path, latest-wins tracker sending, reconnect and refusal.
using System;
using System.Collections.Concurrent;
using System.Collections.Generic;
using System.Linq;
using System.Threading;
using System.Threading.Tasks;
using NUnit.Framework;

namespace Viestac.Client.Tests
{
    /// <summary>A transport the test feeds: Push() a frame from "the server", Close() to drop it.</summary>
    sealed class FakeTransport : ITransport
    {
        readonly BlockingCollection<byte[]> _frames = new BlockingCollection<byte[]>();
        public readonly BlockingCollection<byte[]> Sent = new BlockingCollection<byte[]>();
        public int CloseCode { get; private set; }
        public string CloseReason { get; private set; }

        public Task ConnectAsync(Uri uri, string subprotocol, CancellationToken ct)
        {
            Assert.AreEqual(Protocol.MsgPackSubprotocol, subprotocol);
            return Task.FromResult(0);
        }

        public Task SendAsync(ArraySegment<byte> frame, CancellationToken ct)
        {
            Sent.Add(frame.ToArray());
            return Task.FromResult(0);
        }

        public Task<int> ReceiveAsync(FrameBuffer buffer, CancellationToken ct)
        {
            return Task.Run(() =>
            {
                var f = _frames.Take(ct);
                if (f.Length == 0) { CloseCode = 1001; CloseReason = "going away"; return -1; }
                Array.Copy(f, buffer.Bytes, f.Length);
                return f.Length;
            });
        }

        public void Push(object message) { var w = new MsgPackWriter(); w.WriteValue(message); _frames.Add(w.ToArray()); }
        public void Close() { _frames.Add(new byte[0]); }
        public void Dispose() { }
    }

    [TestFixture]
    public class SessionTests
    {
        static Dictionary<string, object> Vector(string name)
        {
            var root = (Dictionary<string, object>)TestPaths.LoadVectors("messages.json");
            return (Dictionary<string, object>)((List<object>)root["vectors"]).Cast<Dictionary<string, object>>().First(v => (string)v["name"] == name)["message"];
        }

        static Dictionary<string, object> State(long frame)
        {
            var m = new Dictionary<string, object>(Vector("state-free-moving-objects"));
            m["frame"] = frame;
            m["t"] = 10.0 + frame / 60.0;
            return m;
        }

        static bool WaitFor(Func<bool> condition, double seconds = 3)
        {
            var end = DateTime.UtcNow.AddSeconds(seconds);
            while (DateTime.UtcNow < end) { if (condition()) return true; Thread.Sleep(5); }
            return condition();
        }

        static Dictionary<string, object> Decode(byte[] frame) { return (Dictionary<string, object>)new MsgPackReader().ReadFrame(frame); }

        [Test]
        public void SendsHelloWithTokenAndDispatchesOnlyInDrainInOrder()
        {
            var t = new FakeTransport();
            var log = new List<string>();
            var s = new ViestacSession(new SessionOptions { Url = new Uri("ws://x/ws"), Token = "secret", Role = Roles.Operator, TransportFactory = () => t, Log = log.Add });
            var seen = new List<string>();
            s.Welcomed += w => seen.Add("welcome " + w.ClientId);
            s.SceneReceived += sc => seen.Add("scene " + sc.Hash);
            s.StateReceived += st => seen.Add("state " + st.Frame);
            s.Start();
            var hello = Decode(t.Sent.Take());
            Assert.AreEqual("hello", hello["type"]); Assert.AreEqual("secret", hello["token"]); Assert.AreEqual("operator", hello["role"]);
            t.Push(Vector("welcome")); t.Push(Vector("scene-minimal")); t.Push(State(1)); t.Push(State(2));
            Assert.IsTrue(WaitFor(() => s.StatesReceived == 2 && s.Pending >= 4)); // both states read (Pending also counts status changes)
            Assert.IsEmpty(seen, "nothing fires before Drain()");
            int mainThread = Thread.CurrentThread.ManagedThreadId, handlerThread = -1;
            s.StateReceived += _ => handlerThread = Thread.CurrentThread.ManagedThreadId;
            Assert.That(s.Drain(), Is.GreaterThanOrEqualTo(4));
            var welcome = (long)Vector("welcome")["client_id"];
            CollectionAssert.AreEqual(new[] { "welcome " + welcome, "scene " + Vector("scene-minimal")["hash"], "state 1", "state 2" }, seen);
            Assert.AreEqual(mainThread, handlerThread);
            Assert.AreEqual(ConnectionStatus.Connected, s.Status);
            s.Dispose();
        }

        [Test]
        public void DispatchesHealthLeaseAndAskToTheirEvents()
        {
            var t = new FakeTransport();
            var s = new ViestacSession(new SessionOptions { Url = new Uri("ws://x/ws"), Role = Roles.Participant, TransportFactory = () => t, Log = _ => { } });
            var seen = new List<string>();
            s.HealthReceived += h => seen.Add("health " + h.Status);
            s.LeaseReceived += l => seen.Add("lease");
            s.AskReceived += a => seen.Add("ask " + a.Session + " " + a.Questions.Count);
            s.Start();
            t.Sent.Take(); // hello
            t.Push(Vector("welcome")); t.Push(Vector("health-ok")); t.Push(Vector("lease-free")); t.Push(Vector("ask-likert-audio"));
            Assert.IsTrue(WaitFor(() => { s.Drain(); return seen.Count == 3; }));
            var ask = Vector("ask-likert-audio");
            CollectionAssert.AreEqual(new[] { "health " + Vector("health-ok")["status"], "lease",
                                              "ask " + ask["session"] + " " + ((List<object>)ask["questions"]).Count }, seen);
            s.Dispose();
        }

        [Test]
        public void WarnsWhenNobodyDrainsAndDropsTheOldestStatesBeyondTheCap()
        {
            var t = new FakeTransport();
            var log = new List<string>();
            var s = new ViestacSession(new SessionOptions { Url = new Uri("ws://x/ws"), TransportFactory = () => t, Log = m => { lock (log) log.Add(m); }, WarnQueueLength = 10, MaxQueueLength = 20 });
            s.Start();
            t.Push(Vector("welcome"));
            for (int i = 0; i < 40; i++) t.Push(State(i));
            Assert.IsTrue(WaitFor(() => s.StatesReceived == 40));
            lock (log) Assert.IsTrue(log.Any(m => m.Contains("Drain()") && m.Contains("undrained")), string.Join("\n", log));
            Assert.That(s.Pending, Is.LessThanOrEqualTo(20));
            Assert.That(s.DroppedStates, Is.GreaterThan(0));
            var frames = new List<long>();
            s.StateReceived += st => frames.Add(st.Frame);
            s.Drain();
            Assert.AreEqual(39, frames.Last(), "the newest states survive");
            s.Dispose();
        }

        sealed class QueueContext : SynchronizationContext
        {
            public readonly BlockingCollection<Action> Work = new BlockingCollection<Action>();
            public override void Post(SendOrPostCallback d, object state) { Work.Add(() => d(state)); }
        }

        [Test]
        public void ASynchronizationContextGetsTheMessagesWithoutDrain()
        {
            var t = new FakeTransport();
            var ctx = new QueueContext();
            var s = new ViestacSession(new SessionOptions { Url = new Uri("ws://x/ws"), TransportFactory = () => t, Context = ctx, Log = _ => { } });
            var frames = new List<long>();
            s.StateReceived += st => frames.Add(st.Frame);
            s.Start();
            t.Push(Vector("welcome")); t.Push(State(5));
            Action work;
            var end = DateTime.UtcNow.AddSeconds(3);
            while (frames.Count == 0 && DateTime.UtcNow < end)
                if (ctx.Work.TryTake(out work, 50)) work();
            CollectionAssert.AreEqual(new long[] { 5 }, frames);
            s.Dispose();
        }

        [Test]
        public void SendsTheNewestTrackerSampleAndEveryInput()
        {
            var t = new FakeTransport();
            var s = new ViestacSession(new SessionOptions { Url = new Uri("ws://x/ws"), TransportFactory = () => t, Log = _ => { } });
            s.Start();
            t.Sent.Take(); // hello
            s.SendInput("r", InputActions.Press);
            s.SendTracker(new Vec3(0.1, 0.2, 0.3), null, 5);
            var input = Decode(t.Sent.Take(TimeoutToken()));
            Assert.AreEqual("input", input["type"]); Assert.AreEqual("press", input["action"]);
            var tracker = Decode(t.Sent.Take(TimeoutToken()));
            Assert.AreEqual("tracker", tracker["type"]);
            CollectionAssert.AreEqual(new object[] { 0.1, 0.2, 0.3 }, (List<object>)tracker["pos"]);
            Assert.AreEqual(5L, tracker["t"]);
            Assert.AreEqual("out_of_range", Assert.Throws<ProtocolException>(() => s.SendTracker(new Vec3(11, 0, 0))).Code);
            Assert.AreEqual("bad_message", Assert.Throws<ProtocolException>(() => s.SendInput("r", "hold")).Code);
            // v1.4 (assumed until a welcome says otherwise): any tracked point, here with a ttl
            Assert.IsTrue(s.SendTrackerPoint("left.palm", new Vec3(0, 0, 0), null, 40));
            var palm = Decode(t.Sent.Take(TimeoutToken()));
            Assert.AreEqual("left.palm", palm["point"]); Assert.AreEqual(40L, palm["ttl"]);
            s.Dispose();
        }

        [Test]
        public void SendsAHandAsOneSampleWithTheHipInPos()
        {
            var t = new FakeTransport();
            var s = new ViestacSession(new SessionOptions { Url = new Uri("ws://x/ws"), TransportFactory = () => t, Log = _ => { } });
            s.Start();
            t.Sent.Take(); // hello
            var hand = new List<PointPos>
            {
                new PointPos("right.wrist", new Vec3(0, 0.1, 0.8)), new PointPos("right.thumb.tip", new Vec3(0.1, 0.05, 0.4)),
                new PointPos("right.index.tip", new Vec3(0.12, -0.02, 0.45)), new PointPos("right.index.distal", new Vec3(0.11, -0.02, 0.47)),
            };
            Assert.IsTrue(s.SendTrackerPoints(hand, null, 36.5, 1000));
            var m = Decode(t.Sent.Take(TimeoutToken()));
            CollectionAssert.AreEqual(new object[] { 0.12, -0.02, 0.45 }, (List<object>)m["pos"]);
            Assert.IsFalse(m.ContainsKey("point"), "the HIP goes without `point`");
            CollectionAssert.AreEqual(new[] { "right.wrist", "right.thumb.tip", "right.index.distal" }, ((Dictionary<string, object>)m["points"]).Keys.ToList());
            Assert.AreEqual(36.5, m["ttl"]);
            Assert.DoesNotThrow(() => ClientChecks.Check(m));

            // without the HIP the first joint is `pos`, named
            Assert.IsTrue(s.SendTrackerPoints(hand.GetRange(0, 2)));
            m = Decode(t.Sent.Take(TimeoutToken()));
            Assert.AreEqual("right.wrist", m["point"]);
            CollectionAssert.AreEqual(new[] { "right.thumb.tip" }, ((Dictionary<string, object>)m["points"]).Keys.ToList());

            hand[1] = new PointPos("right.thumb.tip", new Vec3(0, 10.5, 0));
            Assert.AreEqual("out_of_range", Assert.Throws<ProtocolException>(() => s.SendTrackerPoints(hand)).Code);
            hand[1] = new PointPos("right.thumb.nail", new Vec3(0, 0, 0));
            Assert.AreEqual("bad_message", Assert.Throws<ProtocolException>(() => s.SendTrackerPoints(hand)).Code);
            Assert.AreEqual("bad_message", Assert.Throws<ProtocolException>(() => s.SendTrackerPoint("right.palm", new Vec3(0, 0, 0), null, 0.5)).Code);
            s.Dispose();
        }

        [Test]
        public void AV13ServerGetsOnlyTheHip()
        {
            var t = new FakeTransport();
            var s = new ViestacSession(new SessionOptions { Url = new Uri("ws://x/ws"), TransportFactory = () => t, Log = _ => { } });
            s.Start();
            t.Sent.Take(); // hello
            var welcome = new Dictionary<string, object>(Vector("welcome"));
            welcome["minor"] = 3L;
            t.Push(welcome);
            Assert.IsTrue(WaitFor(() => { s.Drain(); return s.Welcome != null; }));
            Assert.IsFalse(s.ServerHasPoints);
            Assert.IsFalse(s.SendTrackerPoint("right.thumb.tip", new Vec3(0, 0, 0)), "a v1.3 server would take it for the HIP");
            Assert.IsFalse(s.SendTrackerPoints(new[] { new PointPos("right.thumb.tip", new Vec3(0, 0, 0)) }));
            Assert.IsTrue(s.SendTrackerPoints(new[] { new PointPos("right.thumb.tip", new Vec3(0, 0, 0)), new PointPos("right.index.tip", new Vec3(0.1, 0, 0)) }, null, 40));
            var m = Decode(t.Sent.Take(TimeoutToken()));
            CollectionAssert.AreEqual(new[] { "type", "seq", "t", "pos" }, m.Keys.ToList());
            Assert.AreEqual(0.1, ((List<object>)m["pos"])[0]);
            s.Dispose();
        }

        static CancellationToken TimeoutToken() { return new CancellationTokenSource(3000).Token; }

        [Test]
        public void AQuietConnectionIsDroppedAndReplaced()
        {
            // keepalive: no frame for ReceiveTimeoutS (states come at 60 Hz) means a dead connection
            var transports = new BlockingCollection<FakeTransport>();
            var s = new ViestacSession(new SessionOptions
            {
                Url = new Uri("ws://x/ws"), Log = _ => { }, ReceiveTimeoutS = 0.2,
                Backoff = new Backoff { InitialS = 0.01, MaxS = 0.02 },
                TransportFactory = () => { var f = new FakeTransport(); transports.Add(f); return f; },
            });
            string why = null;
            s.StatusChanged += (st, reason) => { if (st == ConnectionStatus.Reconnecting && reason.Length > 0) why = reason; };
            s.Start();
            var first = transports.Take(TimeoutToken());
            first.Push(Vector("welcome"));
            first.Push(State(1));
            Assert.IsNotNull(transports.Take(TimeoutToken()), "a second connection after the silence");
            Assert.IsTrue(WaitFor(() => { s.Drain(); return why != null; }));
            StringAssert.Contains("no frame for 0.2 s", why);
            s.Dispose();
        }

        [Test]
        public void StatesAreStampedOnArrivalOnTheSessionClock()
        {
            var t = new FakeTransport();
            var s = new ViestacSession(new SessionOptions { Url = new Uri("ws://x/ws"), TransportFactory = () => t, Log = _ => { } });
            var stamps = new List<double>();
            s.StateReceived += st => stamps.Add(st.ReceivedS);
            s.Start();
            t.Push(Vector("welcome")); t.Push(State(1));
            Assert.IsTrue(WaitFor(() => s.Pending >= 2));
            Thread.Sleep(100); // dispatched later than it arrived
            double drainedAt = s.NowS;
            s.Drain();
            Assert.AreEqual(1, stamps.Count);
            Assert.That(stamps[0], Is.GreaterThan(0).And.LessThan(drainedAt - 0.05));
            s.Dispose();
        }

        [Test]
        public void ReconnectsAfterADropAndStopsWhenRefused()
        {
            var transports = new BlockingCollection<FakeTransport>();
            var s = new ViestacSession(new SessionOptions
            {
                Url = new Uri("ws://x/ws"), Log = _ => { },
                Backoff = new Backoff { InitialS = 0.01, MaxS = 0.02 },
                TransportFactory = () => { var f = new FakeTransport(); transports.Add(f); return f; },
            });
            var statuses = new List<ConnectionStatus>();
            s.StatusChanged += (st, _) => statuses.Add(st);
            s.Start();
            var first = transports.Take(TimeoutToken());
            first.Push(Vector("welcome"));
            first.Close();
            var second = transports.Take(TimeoutToken());
            Assert.AreEqual("hello", Decode(second.Sent.Take(TimeoutToken()))["type"], "a new hello on the new connection");
            second.Push(Vector("error-unauthorized"));
            second.Close();
            Assert.IsTrue(WaitFor(() => { s.Drain(); return s.Status == ConnectionStatus.Refused; }));
            Thread.Sleep(100);
            Assert.AreEqual(0, transports.Count, "no reconnect after unauthorized");
            Assert.AreEqual(2, s.Connections);
            CollectionAssert.IsSubsetOf(new[] { ConnectionStatus.Connected, ConnectionStatus.Reconnecting, ConnectionStatus.Refused }, statuses);
            s.Dispose();
        }
    }
}
