// The few REST calls a Unity or console client makes (docs/protocol.md "REST control"): the
// control lease (only its holder may drive the HIP or switch scenarios) and the scenario. The
// token goes in the Authorization header, never in the URL.
using System;
using System.Net.Http;
using System.Net.Http.Headers;
using System.Text;
using System.Threading.Tasks;

namespace Viestac.Client
{
    public sealed class RestAnswer
    {
        public int Status;
        public object Body;
        public bool Ok { get { return Status >= 200 && Status < 300; } }
    }

    public sealed class ViestacRest : IDisposable
    {
        readonly HttpClient _http;

        /// <summary>`baseUrl`: http://HOST:PORT (the /ws URL's scheme http ↔ ws).</summary>
        public ViestacRest(Uri baseUrl, string token)
        {
            _http = new HttpClient { BaseAddress = baseUrl, Timeout = TimeSpan.FromSeconds(10) };
            if (!string.IsNullOrEmpty(token)) _http.DefaultRequestHeaders.Authorization = new AuthenticationHeaderValue("Bearer", token);
        }

        /// <summary>The http(s) base of a ws(s)://HOST:PORT/ws URL.</summary>
        public static Uri BaseOf(Uri ws)
        {
            var b = new UriBuilder(ws) { Scheme = ws.Scheme == "wss" ? "https" : "http", Path = "/" };
            return b.Uri;
        }

        public Task<RestAnswer> Get(string path) { return Send(HttpMethod.Get, path, null); }
        public Task<RestAnswer> Post(string path, object body = null) { return Send(HttpMethod.Post, path, body); }

        /// <summary>Requests (or renews) the control lease: Body["status"] is "granted" or "queued".</summary>
        public Task<RestAnswer> RequestLease() { return Post("api/lease"); }

        /// <summary>Switches the running scenario (lease holder only).</summary>
        public Task<RestAnswer> SwitchScenario(string name, bool force = false)
        {
            var body = new System.Collections.Generic.Dictionary<string, object> { { "name", name }, { "force", force } };
            return Post("api/scenario", body);
        }

        async Task<RestAnswer> Send(HttpMethod method, string path, object body)
        {
            var request = new HttpRequestMessage(method, path.TrimStart('/'));
            if (body != null) request.Content = new StringContent(Json.Write(body), Encoding.UTF8, "application/json");
            using (var response = await _http.SendAsync(request).ConfigureAwait(false))
            {
                var text = await response.Content.ReadAsStringAsync().ConfigureAwait(false);
                object parsed = null;
                try { parsed = text.Length > 0 ? Json.Parse(text) : null; } catch (FormatException) { parsed = text; }
                return new RestAnswer { Status = (int)response.StatusCode, Body = parsed };
            }
        }

        public void Dispose() { _http.Dispose(); }
    }
}
