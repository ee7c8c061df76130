// The socket under a session. ClientWebSocket by default; a WebGL build plugs in a transport over
// the browser's WebSocket (a .jslib) behind the same interface.
using System;
using System.Net.WebSockets;
using System.Threading;
using System.Threading.Tasks;

namespace Viestac.Client
{
    public interface ITransport : IDisposable
    {
        /// <summary>Opens the connection asking for `subprotocol`.</summary>
        Task ConnectAsync(Uri uri, string subprotocol, CancellationToken ct);
        /// <summary>Sends one binary frame. The session never calls it concurrently.</summary>
        Task SendAsync(ArraySegment<byte> frame, CancellationToken ct);
        /// <summary>Receives one whole frame into `buffer` (growing it as needed); returns its
        /// length, or -1 when the server closed the connection.</summary>
        Task<int> ReceiveAsync(FrameBuffer buffer, CancellationToken ct);
        /// <summary>The close status and description after ReceiveAsync returned -1.</summary>
        string CloseReason { get; }
        int CloseCode { get; }
    }

    /// <summary>A reusable receive buffer, so that steady-state receiving allocates nothing.</summary>
    public sealed class FrameBuffer
    {
        public byte[] Bytes = new byte[64 * 1024];
        public void Grow() { Array.Resize(ref Bytes, Bytes.Length * 2); }
    }

    public sealed class ClientWebSocketTransport : ITransport
    {
        public const int MaxFrameBytes = 1 << 20; // the server closes on larger frames anyway
        readonly ClientWebSocket _ws = new ClientWebSocket();
        public string CloseReason { get; private set; }
        public int CloseCode { get; private set; }

        public ClientWebSocketTransport(TimeSpan keepAlive)
        {
            // WebSocket pings keep NAT and proxies from dropping a quiet connection; the session's
            // receive watchdog notices a dead one.
            _ws.Options.KeepAliveInterval = keepAlive;
        }

        public Task ConnectAsync(Uri uri, string subprotocol, CancellationToken ct)
        {
            _ws.Options.AddSubProtocol(subprotocol);
            return _ws.ConnectAsync(uri, ct);
        }

        public Task SendAsync(ArraySegment<byte> frame, CancellationToken ct)
        {
            return _ws.SendAsync(frame, WebSocketMessageType.Binary, true, ct);
        }

        public async Task<int> ReceiveAsync(FrameBuffer buffer, CancellationToken ct)
        {
            int n = 0;
            while (true)
            {
                if (n == buffer.Bytes.Length)
                {
                    if (n >= MaxFrameBytes) throw new ProtocolException("too_large", "a frame over 1 MiB");
                    buffer.Grow();
                }
                var r = await _ws.ReceiveAsync(new ArraySegment<byte>(buffer.Bytes, n, buffer.Bytes.Length - n), ct).ConfigureAwait(false);
                if (r.MessageType == WebSocketMessageType.Close)
                {
                    CloseCode = r.CloseStatus.HasValue ? (int)r.CloseStatus.Value : 1005;
                    CloseReason = r.CloseStatusDescription ?? "";
                    return -1;
                }
                n += r.Count;
                if (r.EndOfMessage) return n;
            }
        }

        public void Dispose()
        {
            try { _ws.Abort(); } catch (Exception) { /* already gone */ }
            _ws.Dispose();
        }
    }
}
