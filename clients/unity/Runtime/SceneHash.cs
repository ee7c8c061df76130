// The scene hash (docs/protocol.md "Scene hash"): the first 16 hex digits of SHA-256 over the
// scene map's canonical JSON (RFC 8785: keys sorted by UTF-16 code units, no whitespace, strings
// and numbers as ECMAScript's JSON.stringify and Number::toString write them), after the
// canonical-number rule. A client recomputes it to check the scene it received.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.Numerics;
using System.Security.Cryptography;
using System.Text;

namespace Viestac.Client
{
    public static class SceneHash
    {
        public static string Of(Dictionary<string, object> scene)
        {
            using (var sha = SHA256.Create())
            {
                var digest = sha.ComputeHash(new UTF8Encoding(false).GetBytes(CanonicalJson(scene)));
                var sb = new StringBuilder(16);
                for (int i = 0; i < 8; i++) sb.Append(digest[i].ToString("x2", CultureInfo.InvariantCulture));
                return sb.ToString();
            }
        }

        public static string CanonicalJson(object value)
        {
            var sb = new StringBuilder();
            Write(sb, value);
            return sb.ToString();
        }

        static void Write(StringBuilder sb, object v)
        {
            if (v == null) { sb.Append("null"); return; }
            if (v is bool) { sb.Append((bool)v ? "true" : "false"); return; }
            if (v is string) { WriteString(sb, (string)v); return; }
            if (v is long || v is int) { sb.Append(NumberToString(Convert.ToInt64(v))); return; }
            if (v is double || v is float) { sb.Append(NumberToString(Convert.ToDouble(v))); return; }
            var map = v as IDictionary<string, object>;
            if (map != null)
            {
                var keys = new List<string>(map.Keys);
                keys.Sort(string.CompareOrdinal); // UTF-16 code units, as RFC 8785 sorts
                sb.Append('{');
                for (int i = 0; i < keys.Count; i++)
                {
                    if (i > 0) sb.Append(',');
                    WriteString(sb, keys[i]);
                    sb.Append(':');
                    Write(sb, map[keys[i]]);
                }
                sb.Append('}');
                return;
            }
            var list = v as System.Collections.IList;
            if (list != null)
            {
                sb.Append('[');
                for (int i = 0; i < list.Count; i++) { if (i > 0) sb.Append(','); Write(sb, list[i]); }
                sb.Append(']');
                return;
            }
            throw new ArgumentException("cannot write " + v.GetType().Name + " as canonical JSON");
        }

        static void WriteString(StringBuilder sb, string s)
        {
            sb.Append('"');
            foreach (char c in s)
            {
                switch (c)
                {
                    case '"': sb.Append("\\\""); break;
                    case '\\': sb.Append("\\\\"); break;
                    case '\b': sb.Append("\\b"); break;
                    case '\t': sb.Append("\\t"); break;
                    case '\n': sb.Append("\\n"); break;
                    case '\f': sb.Append("\\f"); break;
                    case '\r': sb.Append("\\r"); break;
                    default:
                        if (c < 0x20) sb.Append("\\u").Append(((int)c).ToString("x4", CultureInfo.InvariantCulture));
                        else sb.Append(c);
                        break;
                }
            }
            sb.Append('"');
        }

        /// <summary>ECMAScript Number::toString of a float64: the shortest digits that read back
        /// to the same number, in plain or exponent form by its rules. Integral values below 2^53
        /// (the canonical-number rule) come out as integers.</summary>
        public static string NumberToString(double v)
        {
            if (double.IsNaN(v) || double.IsInfinity(v)) throw new ArgumentException("NaN and Infinity have no canonical JSON");
            if (v == 0) return "0";
            if (v < 0) return "-" + NumberToString(-v);
            // The fewest significant digits that read back to v; among several such, the one
            // nearest v (exactly), as ECMAScript asks. The formatter's own last digit can be one
            // off beyond 15 digits, so its neighbours are candidates too.
            string digits = null;
            int exponent = 0;
            for (int p = 1; p <= 17 && digits == null; p++)
            {
                var e = v.ToString("E" + (p - 1), CultureInfo.InvariantCulture); // d.ddddE+xxx
                int ePos = e.IndexOf('E');
                var d = BigInteger.Parse(e.Substring(0, ePos).Replace(".", ""), CultureInfo.InvariantCulture);
                int q = int.Parse(e.Substring(ePos + 1), CultureInfo.InvariantCulture) - (p - 1); // value = d × 10^q
                BigInteger best = BigInteger.MinusOne, bestDistance = BigInteger.Zero;
                for (int delta = -1; delta <= 1; delta++)
                {
                    var c = d + delta;
                    if (c.Sign <= 0 || !ReadsBack(c, q, v)) continue;
                    var distance = BigInteger.Abs(Scaled(c, q, v) - ScaledV(v, q));
                    if (best.Sign < 0 || distance < bestDistance || (distance == bestDistance && c.IsEven)) { best = c; bestDistance = distance; }
                }
                if (best.Sign < 0) continue;
                var text = best.ToString(CultureInfo.InvariantCulture);
                digits = text.TrimEnd('0');
                exponent = q + text.Length - 1;
            }
            if (digits == null) throw new InvalidOperationException("no round-tripping digits for " + v.ToString("R", CultureInfo.InvariantCulture));
            if (digits.Length == 0) digits = "0";
            int k = digits.Length, n = exponent + 1; // value = 0.digits × 10^n
            if (k <= n && n <= 21) return digits + new string('0', n - k);
            if (0 < n && n <= 21) return digits.Substring(0, n) + "." + digits.Substring(n);
            if (-6 < n && n <= 0) return "0." + new string('0', -n) + digits;
            string exp = (n - 1 >= 0 ? "+" : "-") + Math.Abs(n - 1).ToString(CultureInfo.InvariantCulture);
            return k == 1 ? digits + "e" + exp : digits.Substring(0, 1) + "." + digits.Substring(1) + "e" + exp;
        }

        static bool ReadsBack(BigInteger digits, int q, double v)
        {
            double back;
            var text = digits.ToString(CultureInfo.InvariantCulture) + "E" + q.ToString(CultureInfo.InvariantCulture);
            // rounded up past the largest float64 this parse overflows (Mono throws): not it
            return double.TryParse(text, NumberStyles.Float, CultureInfo.InvariantCulture, out back) && back == v;
        }

        // c × 10^q and v = m × 2^e, both times 2^max(0, −e) × 10^max(0, −q): exact integers to compare
        static BigInteger Scaled(BigInteger c, int q, double v)
        {
            int e2 = Exponent2(v);
            return c * BigInteger.Pow(10, Math.Max(0, q)) * BigInteger.Pow(2, Math.Max(0, -e2));
        }

        static BigInteger ScaledV(double v, int q)
        {
            int e2 = Exponent2(v);
            return Mantissa(v) * BigInteger.Pow(2, Math.Max(0, e2)) * BigInteger.Pow(10, Math.Max(0, -q));
        }

        static long Mantissa(double v)
        {
            long bits = BitConverter.DoubleToInt64Bits(v), frac = bits & 0xFFFFFFFFFFFFFL;
            int biased = (int)((bits >> 52) & 0x7FF);
            return biased == 0 ? frac : frac | (1L << 52);
        }

        static int Exponent2(double v)
        {
            int biased = (int)((BitConverter.DoubleToInt64Bits(v) >> 52) & 0x7FF);
            return (biased == 0 ? 1 : biased) - 1075;
        }

        static string NumberToString(long v) { return Math.Abs(v) < 9007199254740992L ? v.ToString(CultureInfo.InvariantCulture) : NumberToString((double)v); }
    }
}
