// MessagePack for exactly this protocol (docs/protocol.md "Encoding"): a writer and a reader with
// no reflection, so that Unity's AOT (IL2CPP) builds keep working. Every integer width and
// float32/float64 are read; the writer writes canonical numbers (integral values below 2^53 as
// the smallest int form, everything else float64), byte for byte what the server's codec writes.
using System;
using System.Collections.Generic;
using System.Text;

namespace Viestac.Client
{
    /// <summary>A frame the protocol refuses, with its error code (`bad_encoding`, `bad_message`, `non_finite`, ...).</summary>
    public sealed class ProtocolException : Exception
    {
        public readonly string Code;
        public ProtocolException(string code, string message) : base(message) { Code = code; }
    }

    public sealed class MsgPackWriter
    {
        const double TwoTo53 = 9007199254740992.0;
        static readonly UTF8Encoding Utf8 = new UTF8Encoding(false, true);
        byte[] _buf;
        int _len;

        public MsgPackWriter(int capacity = 256) { _buf = new byte[Math.Max(16, capacity)]; }

        public int Length { get { return _len; } }
        /// <summary>The internal buffer; valid up to Length until the next Clear or write.</summary>
        public byte[] Buffer { get { return _buf; } }
        public ArraySegment<byte> Segment { get { return new ArraySegment<byte>(_buf, 0, _len); } }
        public void Clear() { _len = 0; }
        public byte[] ToArray() { var a = new byte[_len]; Array.Copy(_buf, a, _len); return a; }

        void Ensure(int n)
        {
            if (_len + n <= _buf.Length) return;
            var bigger = new byte[Math.Max(_buf.Length * 2, _len + n)];
            Array.Copy(_buf, bigger, _len);
            _buf = bigger;
        }

        void Byte(byte b) { Ensure(1); _buf[_len++] = b; }
        void BigEndian(ulong v, int bytes)
        {
            Ensure(bytes);
            for (int i = bytes - 1; i >= 0; i--) _buf[_len++] = (byte)(v >> (8 * i));
        }

        public void WriteNil() { Byte(0xc0); }
        public void WriteBool(bool v) { Byte(v ? (byte)0xc3 : (byte)0xc2); }

        public void WriteMapHeader(int count)
        {
            if (count < 16) Byte((byte)(0x80 | count));
            else if (count <= 0xffff) { Byte(0xde); BigEndian((ulong)count, 2); }
            else { Byte(0xdf); BigEndian((ulong)count, 4); }
        }

        public void WriteArrayHeader(int count)
        {
            if (count < 16) Byte((byte)(0x90 | count));
            else if (count <= 0xffff) { Byte(0xdc); BigEndian((ulong)count, 2); }
            else { Byte(0xdd); BigEndian((ulong)count, 4); }
        }

        /// <summary>The smallest form: unsigned forms for v ≥ 0, signed forms below (as msgpack-python and msgpackr write).</summary>
        public void WriteInt(long v)
        {
            if (v >= 0)
            {
                if (v < 128) Byte((byte)v);
                else if (v <= 0xff) { Byte(0xcc); BigEndian((ulong)v, 1); }
                else if (v <= 0xffff) { Byte(0xcd); BigEndian((ulong)v, 2); }
                else if (v <= 0xffffffffL) { Byte(0xce); BigEndian((ulong)v, 4); }
                else { Byte(0xcf); BigEndian((ulong)v, 8); }
            }
            else
            {
                if (v >= -32) Byte((byte)(sbyte)v);
                else if (v >= sbyte.MinValue) { Byte(0xd0); BigEndian((ulong)v, 1); }
                else if (v >= short.MinValue) { Byte(0xd1); BigEndian((ulong)v, 2); }
                else if (v >= int.MinValue) { Byte(0xd2); BigEndian((ulong)v, 4); }
                else { Byte(0xd3); BigEndian((ulong)v, 8); }
            }
        }

        public void WriteFloat64(double v) { Byte(0xcb); BigEndian((ulong)BitConverter.DoubleToInt64Bits(v), 8); }

        public void WriteFloat32(float v)
        {
            Byte(0xca);
            BigEndian((uint)BitConverter.ToInt32(BitConverter.GetBytes(v), 0), 4);
        }

        /// <summary>The canonical number rule: integral and below 2^53 in magnitude → int, else float64.
        /// Non-finite numbers are never valid on the wire.</summary>
        public void WriteNumber(double v)
        {
            if (double.IsNaN(v) || double.IsInfinity(v))
                throw new ArgumentException("NaN and Infinity are never valid on the wire");
            if (Math.Floor(v) == v && Math.Abs(v) < TwoTo53) WriteInt((long)v);
            else WriteFloat64(v);
        }

        public void WriteString(string s)
        {
            int n = Utf8.GetByteCount(s);
            if (n < 32) Byte((byte)(0xa0 | n));
            else if (n <= 0xff) { Byte(0xd9); BigEndian((ulong)n, 1); }
            else if (n <= 0xffff) { Byte(0xda); BigEndian((ulong)n, 2); }
            else { Byte(0xdb); BigEndian((ulong)n, 4); }
            Ensure(n);
            _len += Utf8.GetBytes(s, 0, s.Length, _buf, _len);
        }

        /// <summary>Any decoded value: null, bool, long/int, double/float (canonical), string,
        /// IDictionary&lt;string, object&gt; (in its enumeration order), IList.</summary>
        public void WriteValue(object value)
        {
            if (value == null) { WriteNil(); return; }
            if (value is bool) { WriteBool((bool)value); return; }
            if (value is string) { WriteString((string)value); return; }
            if (value is long) { WriteInt((long)value); return; }
            if (value is int) { WriteInt((int)value); return; }
            if (value is double) { WriteNumber((double)value); return; }
            if (value is float) { WriteNumber((float)value); return; }
            var map = value as IDictionary<string, object>;
            if (map != null)
            {
                WriteMapHeader(map.Count);
                foreach (var kv in map) { WriteString(kv.Key); WriteValue(kv.Value); }
                return;
            }
            var list = value as System.Collections.IList;
            if (list != null)
            {
                WriteArrayHeader(list.Count);
                for (int i = 0; i < list.Count; i++) WriteValue(list[i]);
                return;
            }
            throw new ArgumentException("cannot encode " + value.GetType().Name);
        }
    }

    /// <summary>Returns the same string instance for the same short UTF-8 bytes (map keys, object
    /// ids, cue kinds), so steady-state frames allocate no strings for them.</summary>
    public sealed class StringCache
    {
        const int Slots = 512, MaxBytes = 48;
        readonly byte[][] _bytes = new byte[Slots][];
        readonly string[] _strings = new string[Slots];
        static readonly UTF8Encoding Utf8 = new UTF8Encoding(false, true);

        public string Get(byte[] buf, int offset, int count)
        {
            if (count > MaxBytes) return Decode(buf, offset, count);
            uint h = 2166136261;
            for (int i = 0; i < count; i++) h = (h ^ buf[offset + i]) * 16777619;
            int slot = (int)(h % Slots);
            var cached = _bytes[slot];
            if (cached != null && cached.Length == count)
            {
                bool same = true;
                for (int i = 0; i < count && same; i++) same = cached[i] == buf[offset + i];
                if (same) return _strings[slot];
            }
            var s = Decode(buf, offset, count);
            var copy = new byte[count];
            Array.Copy(buf, offset, copy, 0, count);
            _bytes[slot] = copy;
            _strings[slot] = s;
            return s;
        }

        static string Decode(byte[] buf, int offset, int count)
        {
            try { return Utf8.GetString(buf, offset, count); }
            catch (DecoderFallbackException) { throw new ProtocolException("bad_encoding", "a string is not valid UTF-8"); }
        }
    }

    /// <summary>Reads one msgpack value from a buffer into plain objects: null, bool, long, double,
    /// string, byte[], Dictionary&lt;string, object&gt; (keys in wire order), List&lt;object&gt;. Refuses
    /// what the protocol refuses anywhere in a frame: non-finite floats (`non_finite`), nesting
    /// deeper than 32 and non-string map keys (`bad_message`), truncation, reserved bytes and
    /// trailing bytes (`bad_encoding`).</summary>
    public sealed class MsgPackReader
    {
        public const int MaxDepth = 32;
        readonly StringCache _strings;
        byte[] _buf;
        int _pos, _end;

        public MsgPackReader(StringCache strings = null) { _strings = strings ?? new StringCache(); }

        public object ReadFrame(byte[] buf, int offset, int count)
        {
            _buf = buf; _pos = offset; _end = offset + count;
            var value = ReadValue(0);
            if (_pos != _end) throw new ProtocolException("bad_encoding", "bytes after the msgpack value");
            return value;
        }

        public object ReadFrame(byte[] frame) { return ReadFrame(frame, 0, frame.Length); }

        void Need(int n)
        {
            if (_end - _pos < n) throw new ProtocolException("bad_encoding", "the msgpack frame is truncated");
        }

        ulong Big(int bytes)
        {
            Need(bytes);
            ulong v = 0;
            for (int i = 0; i < bytes; i++) v = (v << 8) | _buf[_pos++];
            return v;
        }

        static double Finite(double v)
        {
            if (double.IsNaN(v) || double.IsInfinity(v)) throw new ProtocolException("non_finite", "NaN or Infinity in a number");
            return v;
        }

        object ReadValue(int depth)
        {
            Need(1);
            byte b = _buf[_pos++];
            if (b <= 0x7f) return (long)b;
            if (b >= 0xe0) return (long)(sbyte)b;
            if (b >= 0xa0 && b <= 0xbf) return Str(b & 0x1f);
            if (b >= 0x80 && b <= 0x8f) return Map(b & 0x0f, depth);
            if (b >= 0x90 && b <= 0x9f) return Arr(b & 0x0f, depth);
            switch (b)
            {
                case 0xc0: return null;
                case 0xc2: return false;
                case 0xc3: return true;
                case 0xc4: return Bin((int)Big(1));
                case 0xc5: return Bin((int)Big(2));
                case 0xc6: return Bin(Len32());
                case 0xca:
                {
                    var bits = (int)(uint)Big(4);
                    return Finite(BitConverter.ToSingle(BitConverter.GetBytes(bits), 0));
                }
                case 0xcb: return Finite(BitConverter.Int64BitsToDouble((long)Big(8)));
                case 0xcc: return (long)Big(1);
                case 0xcd: return (long)Big(2);
                case 0xce: return (long)Big(4);
                case 0xcf:
                {
                    ulong u = Big(8);
                    // beyond long: still a number (the field check calls it out of range)
                    return u > long.MaxValue ? (object)(double)u : (long)u;
                }
                case 0xd0: return (long)(sbyte)Big(1);
                case 0xd1: return (long)(short)Big(2);
                case 0xd2: return (long)(int)Big(4);
                case 0xd3: return (long)Big(8);
                case 0xd9: return Str((int)Big(1));
                case 0xda: return Str((int)Big(2));
                case 0xdb: return Str(Len32());
                case 0xdc: return Arr((int)Big(2), depth);
                case 0xdd: return Arr(Len32(), depth);
                case 0xde: return Map((int)Big(2), depth);
                case 0xdf: return Map(Len32(), depth);
                default: throw new ProtocolException("bad_encoding", string.Format("msgpack type 0x{0:x2} is not used by this protocol", b));
            }
        }

        int Len32()
        {
            ulong n = Big(4);
            if (n > int.MaxValue) throw new ProtocolException("bad_encoding", "the msgpack frame is truncated");
            return (int)n;
        }

        string Str(int n)
        {
            Need(n);
            var s = _strings.Get(_buf, _pos, n);
            _pos += n;
            return s;
        }

        byte[] Bin(int n)
        {
            Need(n);
            var a = new byte[n];
            Array.Copy(_buf, _pos, a, 0, n);
            _pos += n;
            return a;
        }

        List<object> Arr(int n, int depth)
        {
            if (depth + 1 > MaxDepth) throw new ProtocolException("bad_message", "nested deeper than 32");
            Need(n); // each element takes at least one byte: refuse absurd counts before allocating
            var list = new List<object>(n);
            for (int i = 0; i < n; i++) list.Add(ReadValue(depth + 1));
            return list;
        }

        Dictionary<string, object> Map(int n, int depth)
        {
            if (depth + 1 > MaxDepth) throw new ProtocolException("bad_message", "nested deeper than 32");
            Need(2 * n);
            // Dictionary keeps insertion order while nothing is removed: keys stay in wire order.
            var map = new Dictionary<string, object>(n);
            for (int i = 0; i < n; i++)
            {
                var key = ReadValue(depth + 1) as string;
                if (key == null) throw new ProtocolException("bad_message", "a map key is not a string");
                map[key] = ReadValue(depth + 1);
            }
            return map;
        }
    }
}
