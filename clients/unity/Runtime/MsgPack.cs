// MessagePack for exactly this protocol (docs/protocol.md "Encoding"): a writer and a reader with
// no reflection, so that Unity's AOT (IL2CPP) builds keep working. Every integer width and
// float32/float64 are read; the writer writes canonical numbers (integral values below 2^53 as
// the smallest int form, everything else float64), byte for byte what the server's codec writes.
using System;
using System.Collections.Generic;
using System.Text;

namespace Viestac.Client
{
    /// <summary>float32 ↔ its bits without allocating (BitConverter.GetBytes would).</summary>
    [System.Runtime.InteropServices.StructLayout(System.Runtime.InteropServices.LayoutKind.Explicit)]
    struct FloatBits
    {
        [System.Runtime.InteropServices.FieldOffset(0)] public int I;
        [System.Runtime.InteropServices.FieldOffset(0)] public float F;
    }

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
            BigEndian((uint)new FloatBits { F = v }.I, 4);
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
    /// ids, cue kinds, the scene hash, the HUD), so steady-state frames allocate no strings for
    /// them. Four-way: a string that shares a slot with another still stays.</summary>
    public sealed class StringCache
    {
        const int Slots = 1024, Ways = 4, MaxBytes = 96;
        readonly byte[][] _bytes = new byte[Slots][];
        readonly string[] _strings = new string[Slots];
        int _evict;
        static readonly UTF8Encoding Utf8 = new UTF8Encoding(false, true);

        public string Get(byte[] buf, int offset, int count)
        {
            if (count > MaxBytes) return Decode(buf, offset, count);
            uint h = 2166136261;
            for (int i = 0; i < count; i++) h = (h ^ buf[offset + i]) * 16777619;
            int set = (int)(h % (Slots / Ways)) * Ways, free = -1;
            for (int w = 0; w < Ways; w++)
            {
                var cached = _bytes[set + w];
                if (cached == null) { if (free < 0) free = set + w; continue; }
                if (cached.Length != count) continue;
                bool same = true;
                for (int i = 0; i < count && same; i++) same = cached[i] == buf[offset + i];
                if (same) return _strings[set + w];
            }
            var s = Decode(buf, offset, count);
            var copy = new byte[count];
            Array.Copy(buf, offset, copy, 0, count);
            int slot = free >= 0 ? free : set + (_evict++ & (Ways - 1));
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

        static readonly object True = true, False = false; // one box each, not one per value

        // ---- cursor: typed decoding (Protocol's state frames) without building a tree ----------

        public void Begin(byte[] buf, int offset, int count) { _buf = buf; _pos = offset; _end = offset + count; }
        public int Position { get { return _pos; } set { _pos = value; } }

        public void EndFrame()
        {
            if (_pos != _end) throw new ProtocolException("bad_encoding", "bytes after the msgpack value");
        }

        public bool TryReadNil()
        {
            Need(1);
            if (_buf[_pos] != 0xc0) return false;
            _pos++;
            return true;
        }

        public bool IsString { get { Need(1); byte b = _buf[_pos]; return (b >= 0xa0 && b <= 0xbf) || (b >= 0xd9 && b <= 0xdb); } }
        public bool IsMap { get { Need(1); byte b = _buf[_pos]; return (b >= 0x80 && b <= 0x8f) || b == 0xde || b == 0xdf; } }

        static ProtocolException Bad(string what) { return new ProtocolException("bad_message", what); }

        public int ReadMapHeader(string what)
        {
            Need(1);
            byte b = _buf[_pos];
            int n;
            if (b >= 0x80 && b <= 0x8f) { _pos++; n = b & 0x0f; }
            else if (b == 0xde) { _pos++; n = (int)Big(2); }
            else if (b == 0xdf) { _pos++; n = Len32(); }
            else throw Bad(what + " is a map");
            Need(2 * n);
            return n;
        }

        public int ReadArrayHeader(string what)
        {
            Need(1);
            byte b = _buf[_pos];
            int n;
            if (b >= 0x90 && b <= 0x9f) { _pos++; n = b & 0x0f; }
            else if (b == 0xdc) { _pos++; n = (int)Big(2); }
            else if (b == 0xdd) { _pos++; n = Len32(); }
            else throw Bad(what + " is an array");
            Need(n);
            return n;
        }

        public string ReadString(string what)
        {
            if (!IsString) throw Bad(what + " is a string");
            return (string)ReadValue(0);
        }

        public bool ReadBool(string what)
        {
            Need(1);
            byte b = _buf[_pos];
            if (b != 0xc2 && b != 0xc3) throw Bad(what + " is a bool");
            _pos++;
            return b == 0xc3;
        }

        public bool IsBool { get { Need(1); return _buf[_pos] == 0xc2 || _buf[_pos] == 0xc3; } }

        public bool IsNumber
        {
            get { Need(1); byte b = _buf[_pos]; return b <= 0x7f || b >= 0xe0 || (b >= 0xca && b <= 0xd3); }
        }

        /// <summary>An int or float as a double, without boxing it.</summary>
        public double ReadNumber(string what)
        {
            if (!IsNumber) throw Bad(what + " is a number");
            byte b = _buf[_pos];
            if (b == 0xca) { _pos++; return Finite(new FloatBits { I = (int)(uint)Big(4) }.F); }
            if (b == 0xcb) { _pos++; return Finite(BitConverter.Int64BitsToDouble((long)Big(8))); }
            if (b == 0xcf)
            {
                _pos++;
                return Big(8); // ulong → double: beyond long it is out of range for the field check anyway
            }
            return ReadInt64Raw();
        }

        /// <summary>Any value, as ReadFrame gives it, at nesting level `depth`; a number equal to
        /// `previous` (same kind) returns `previous` itself, so unchanged values allocate nothing.</summary>
        public object ReadValue(int depth, object previous)
        {
            Need(1);
            byte b = _buf[_pos];
            if (previous is long && (b <= 0x7f || b >= 0xe0 || (b >= 0xcc && b <= 0xd3)))
            {
                int at = _pos;
                long v = ReadInt64Raw();
                if (v == (long)previous) return previous;
                _pos = at;
            }
            else if (previous is double && b == 0xcb)
            {
                int at = _pos;
                _pos++;
                long bits = (long)Big(8);
                if (bits == BitConverter.DoubleToInt64Bits((double)previous)) return previous;
                _pos = at;
            }
            return ReadValue(depth);
        }

        long ReadInt64Raw()
        {
            byte b = _buf[_pos++];
            if (b <= 0x7f) return b;
            if (b >= 0xe0) return (sbyte)b;
            switch (b)
            {
                case 0xcc: return (long)Big(1);
                case 0xcd: return (long)Big(2);
                case 0xce: return (long)Big(4);
                case 0xcf: { ulong u = Big(8); return u > long.MaxValue ? long.MinValue : (long)u; }
                case 0xd0: return (sbyte)Big(1);
                case 0xd1: return (short)Big(2);
                case 0xd2: return (int)Big(4);
                default: return (long)Big(8);
            }
        }

        /// <summary>Passes over one value with the checks ReadFrame makes (finite floats, UTF-8,
        /// nesting), allocating nothing.</summary>
        public void Skip(int depth)
        {
            Need(1);
            byte b = _buf[_pos];
            int n;
            if (b <= 0x7f || b >= 0xe0 || b == 0xc0 || b == 0xc2 || b == 0xc3) { _pos++; return; }
            if ((b >= 0xa0 && b <= 0xbf) || (b >= 0xd9 && b <= 0xdb))
            {
                _pos++;
                n = b <= 0xbf ? b & 0x1f : b == 0xd9 ? (int)Big(1) : b == 0xda ? (int)Big(2) : Len32();
                Need(n);
                try { StrictUtf8.GetCharCount(_buf, _pos, n); }
                catch (DecoderFallbackException) { throw new ProtocolException("bad_encoding", "a string is not valid UTF-8"); }
                _pos += n;
                return;
            }
            if ((b >= 0x80 && b <= 0x8f) || b == 0xde || b == 0xdf)
            {
                if (depth + 1 > MaxDepth) throw Bad("nested deeper than 32");
                n = ReadMapHeader("");
                for (int i = 0; i < n; i++)
                {
                    if (!IsString) throw Bad("a map key is not a string");
                    Skip(depth + 1); Skip(depth + 1);
                }
                return;
            }
            if ((b >= 0x90 && b <= 0x9f) || b == 0xdc || b == 0xdd)
            {
                if (depth + 1 > MaxDepth) throw Bad("nested deeper than 32");
                n = ReadArrayHeader("");
                for (int i = 0; i < n; i++) Skip(depth + 1);
                return;
            }
            if (b == 0xca) { _pos++; var bits = (int)(uint)Big(4); Finite(new FloatBits { I = bits }.F); return; }
            if (b == 0xcb) { _pos++; Finite(BitConverter.Int64BitsToDouble((long)Big(8))); return; }
            ReadValue(depth); // the other ints, bin, and the refusals
        }

        static readonly UTF8Encoding StrictUtf8 = new UTF8Encoding(false, true);

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
                case 0xc2: return False;
                case 0xc3: return True;
                case 0xc4: return Bin((int)Big(1));
                case 0xc5: return Bin((int)Big(2));
                case 0xc6: return Bin(Len32());
                case 0xca:
                {
                    var bits = (int)(uint)Big(4);
                    return Finite(new FloatBits { I = bits }.F);
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
