// C# bindings of libinertia (client-ffi/include/inertia.h), by P/Invoke:
// the path Unity's Mono and IL2CPP take. The structs mirror the header's
// field by field; `InertiaClient` wraps a handle with exceptions and
// IDisposable. Under IL2CPP on platforms that link statically (iOS,
// consoles), set `Native.Lib` to "__Internal".

using System;
using System.Runtime.InteropServices;
using System.Text;

namespace Inertia
{
    public enum Status : int
    {
        Ok = 0,
        InvalidArgument = 1,
        ConnectFailed = 2,
        Disconnected = 3,
        BufferTooSmall = 4,
        NotFound = 5,
        Internal = 6,
    }

    public enum EntityKind : uint { Static, Dynamic, Kinematic, Avatar, Water, SoftBody, Fluid }

    public enum ShapeKind : uint
    {
        Sphere, Cuboid, Capsule, Cylinder, ConvexHull, TriMesh, Compound, Particle, Ground, HeightField, PointSet,
    }

    public enum EventKind : uint
    {
        None, Spawned, Despawned, Discontinuity, Resync, Disconnected, Message, Properties, MatchState,
        ReplayStarted, ReplayRefused, ReplayEnded,
    }

    /// <summary>How a game message travels.</summary>
    public enum Delivery : uint { Reliable, Unreliable }

    [StructLayout(LayoutKind.Sequential)]
    public struct ServerInfo
    {
        public ulong ClientId;
        public ulong Tick;
        public uint TickHz;
        public uint SnapshotHz;
        public double PositionResolution;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 64)] public byte[] ServerVersion;
        /// <summary>Bytes of the game's input (<see cref="Client.SetInput{T}"/> sends a struct of exactly this size).</summary>
        public uint InputBytes;
        /// <summary>Properties the game declares per entity, and per match.</summary>
        public uint EntityProperties, MatchProperties;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 33)] public byte[] GameBytes;

        /// <summary>The game's name (empty when its rules give none).</summary>
        public string Game => Native.Text(GameBytes);
    }

    public enum PropertyKind : uint { Bool, UInt, Int, F32 }

    /// <summary>One property the game declares.</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct PropertyDecl
    {
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 33)] public byte[] NameBytes;
        public PropertyKind Kind;
        public uint Bits;

        public string Name => Native.Text(NameBytes);
    }

    /// <summary>One property's value: read the field of its kind (a flag is 0 or 1 in all).</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct PropertyValue
    {
        public PropertyKind Kind;
        public ulong AsU64;
        public long AsI64;
        public double AsF64;

        public override string ToString() =>
            Kind == PropertyKind.Bool ? (AsU64 != 0).ToString()
            : Kind == PropertyKind.UInt ? AsU64.ToString()
            : Kind == PropertyKind.Int ? AsI64.ToString()
            : AsF64.ToString();
    }

    /// <summary>One entity where the picture draws it (blittable).</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct EntityState
    {
        public uint Id;
        public byte Extrapolated;
        public double X, Y, Z;
        public double Qx, Qy, Qz, Qw;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct EntityInfo
    {
        public uint Id;
        public EntityKind Kind;
        public ShapeKind Shape;
        public uint Points;
        public float Dim0, Dim1, Dim2;
        public byte R, G, B, A;
        public byte HasOwner;
        public ulong Owner;
        public double X, Y, Z;
        public double Qx, Qy, Qz, Qw;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 65)] public byte[] NameBytes;

        public string Name => Native.Text(NameBytes);
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct Event
    {
        public EventKind Kind;
        public uint Entity;
        public Delivery Delivery;
        public double FromTick, ToTick;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 256)] public byte[] TextBytes;
        public uint DataLen;
        [MarshalAs(UnmanagedType.ByValArray, SizeConst = 1024)] public byte[] Data;

        public string Text => Native.Text(TextBytes);

        /// <summary>A message's bytes (kind Message), as the game lays its messages out.</summary>
        public byte[] MessageBytes
        {
            get
            {
                var bytes = new byte[DataLen];
                Array.Copy(Data, bytes, (int)DataLen);
                return bytes;
            }
        }
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct Stats
    {
        public double RttMs, Loss, Kbps, BufferMs, DelayMs;
        public ulong SnapshotsReceived, BytesReceived, Stalls, Discontinuities;
        public double JitterMs, KbpsOut, InputMarginTicks;
        public ulong InputTick, InputsOnTime, InputsLate, InputsRefused;
        public double PredictionErrorP99M, PredictionErrorMaxM, PredictionSnapMaxM;
        public ulong PredictionCorrections;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct ConnectOptions
    {
        /// <summary>Nonzero: predict the own avatar.</summary>
        public byte Predict;
    }

    /// <summary>The library's functions, one to one with the header.</summary>
    public static class Native
    {
        public const string Lib = "inertia";
        public const uint AbiVersion = 5;
        /// <summary>No entity: a replay centred on the player's own avatar.</summary>
        public const uint NoEntity = uint.MaxValue;

        [DllImport(Lib)] public static extern uint inertia_abi_version();
        [DllImport(Lib)] public static extern UIntPtr inertia_last_error(byte[] buf, UIntPtr len);
        [DllImport(Lib)] public static extern Status inertia_connect(byte[] address, byte[] token, UIntPtr tokenLen, out IntPtr client);
        [DllImport(Lib)] public static extern Status inertia_connect_with(byte[] address, byte[] token, UIntPtr tokenLen, ref ConnectOptions options, out IntPtr client);
        [DllImport(Lib)] public static extern Status inertia_connect_dev(byte[] credentialsPath, ulong clientId, out IntPtr client);
        [DllImport(Lib)] public static extern void inertia_disconnect(IntPtr client);
        [DllImport(Lib)] public static extern Status inertia_server_info(IntPtr client, out ServerInfo info);
        [DllImport(Lib)] public static extern Status inertia_set_input(IntPtr client, float moveX, float moveZ, float yaw, byte buttons);
        [DllImport(Lib)] public static extern Status inertia_set_input_bytes(IntPtr client, byte[] bytes, UIntPtr len);
        [DllImport(Lib)] public static extern Status inertia_send_message(IntPtr client, byte[] bytes, UIntPtr len, Delivery delivery);
        [DllImport(Lib)] public static extern Status inertia_poll_event(IntPtr client, out Event e);
        [DllImport(Lib)] public static extern Status inertia_property_decl(IntPtr client, byte ofMatch, uint index, out PropertyDecl decl);
        [DllImport(Lib)] public static extern Status inertia_properties(IntPtr client, uint entity, [Out] PropertyValue[] values, UIntPtr capacity, out UIntPtr count);
        [DllImport(Lib)] public static extern Status inertia_match_state(IntPtr client, [Out] PropertyValue[] values, UIntPtr capacity, out UIntPtr count);
        [DllImport(Lib)] public static extern Status inertia_sample(IntPtr client, [Out] EntityState[] states, UIntPtr capacity, out UIntPtr count);
        [DllImport(Lib)] public static extern Status inertia_kill_cam(IntPtr client, float seconds, float speed, uint focus);
        [DllImport(Lib)] public static extern Status inertia_replay(IntPtr client, ulong fromTick, ulong toTick, float speed, uint focus);
        [DllImport(Lib)] public static extern Status inertia_cancel_replay(IntPtr client);
        [DllImport(Lib)] public static extern Status inertia_replay_sample(IntPtr client, [Out] EntityState[] states, UIntPtr capacity, out UIntPtr count);
        [DllImport(Lib)] public static extern Status inertia_entity_info(IntPtr client, uint id, out EntityInfo info);
        [DllImport(Lib)] public static extern Status inertia_point_set(IntPtr client, uint set, [Out] float[] positions, [Out] byte[] present, UIntPtr capacity, out UIntPtr count);
        [DllImport(Lib)] public static extern Status inertia_point_set_triangles(IntPtr client, uint set, [Out] uint[] indices, UIntPtr capacity, out UIntPtr count);
        [DllImport(Lib)] public static extern Status inertia_stats(IntPtr client, out Stats stats);

        /// <summary>A NUL-terminated UTF-8 string for the library.</summary>
        public static byte[] CString(string s)
        {
            var bytes = Encoding.UTF8.GetBytes(s);
            Array.Resize(ref bytes, bytes.Length + 1);
            return bytes;
        }

        /// <summary>A NUL-terminated UTF-8 field as a string.</summary>
        public static string Text(byte[] field)
        {
            if (field == null) return "";
            int n = Array.IndexOf(field, (byte)0);
            return Encoding.UTF8.GetString(field, 0, n < 0 ? field.Length : n);
        }

        public static string LastError()
        {
            var buf = new byte[1024];
            inertia_last_error(buf, (UIntPtr)buf.Length);
            return Text(buf);
        }
    }

    public class InertiaException : Exception
    {
        public readonly Status Status;
        public InertiaException(Status status, string what) : base(what + ": " + status + ": " + Native.LastError()) { Status = status; }
    }

    /// <summary>A connection to an Inertia server. Use it from one thread at a time.</summary>
    public sealed class InertiaClient : IDisposable
    {
        IntPtr handle;

        InertiaClient(IntPtr handle) { this.handle = handle; }

        static void Check(Status s, string what)
        {
            if (s != Status.Ok) throw new InertiaException(s, what);
        }

        static void CheckAbi()
        {
            if (Native.inertia_abi_version() != Native.AbiVersion)
                throw new InvalidOperationException("libinertia's ABI is " + Native.inertia_abi_version() + ", these bindings' " + Native.AbiVersion);
        }

        public static InertiaClient Connect(string address, byte[] token, bool predict = false)
        {
            CheckAbi();
            IntPtr h;
            var options = new ConnectOptions { Predict = (byte)(predict ? 1 : 0) };
            Check(Native.inertia_connect_with(Native.CString(address), token, (UIntPtr)token.Length, ref options, out h), "connect");
            return new InertiaClient(h);
        }

        public static InertiaClient ConnectDev(string credentialsPath)
        {
            CheckAbi();
            IntPtr h;
            Check(Native.inertia_connect_dev(Native.CString(credentialsPath), 0, out h), "connect");
            return new InertiaClient(h);
        }

        public ServerInfo Info { get { ServerInfo i; Check(Native.inertia_server_info(handle, out i), "server info"); return i; } }

        /// <summary>The sandbox game's input (the stock server's).</summary>
        public void SetInput(float moveX, float moveZ, float yaw, byte buttons) =>
            Check(Native.inertia_set_input(handle, moveX, moveZ, yaw, buttons), "set input");

        /// <summary>The game's input: a blittable struct laid out as the game
        /// lays its input out (<c>[StructLayout(LayoutKind.Sequential, Pack = 1)]</c>),
        /// exactly <see cref="ServerInfo.InputBytes"/> long.</summary>
        public void SetInput<T>(T input) where T : struct
        {
            int size = Marshal.SizeOf<T>();
            var bytes = new byte[size];
            IntPtr at = Marshal.AllocHGlobal(size);
            try
            {
                Marshal.StructureToPtr(input, at, false);
                Marshal.Copy(at, bytes, 0, size);
            }
            finally
            {
                Marshal.FreeHGlobal(at);
            }
            Check(Native.inertia_set_input_bytes(handle, bytes, (UIntPtr)size), "set input");
        }

        /// <summary>Sends a message of the game's to the server's rules, laid out as the
        /// game lays its messages out (at most 1024 bytes).</summary>
        public void SendMessage(byte[] bytes, Delivery delivery = Delivery.Reliable) =>
            Check(Native.inertia_send_message(handle, bytes, (UIntPtr)bytes.Length, delivery), "send message");

        /// <summary>Declaration <paramref name="index"/> of the game's match or entity properties.</summary>
        public PropertyDecl PropertyDecl(bool ofMatch, uint index)
        {
            PropertyDecl d;
            Check(Native.inertia_property_decl(handle, (byte)(ofMatch ? 1 : 0), index, out d), "property declaration");
            return d;
        }

        /// <summary>An entity's properties as of the tick last drawn, in the schema's order; null for an entity not in view.</summary>
        public PropertyValue[] Properties(uint entity)
        {
            var values = new PropertyValue[Info.EntityProperties];
            UIntPtr count;
            var s = Native.inertia_properties(handle, entity, values, (UIntPtr)values.Length, out count);
            if (s == Status.NotFound) return null;
            Check(s, "properties");
            return values;
        }

        /// <summary>The match's properties (the score, the clock) as of the tick last drawn.</summary>
        public PropertyValue[] MatchState()
        {
            var values = new PropertyValue[Info.MatchProperties];
            UIntPtr count;
            Check(Native.inertia_match_state(handle, values, (UIntPtr)values.Length, out count), "match state");
            return values;
        }

        /// <summary>The next waiting event, or one of kind None.</summary>
        public Event PollEvent() { Event e; Check(Native.inertia_poll_event(handle, out e), "poll event"); return e; }

        /// <summary>Draws the world now into `states`; returns how many the picture holds.</summary>
        public int Sample(EntityState[] states)
        {
            UIntPtr count;
            var s = Native.inertia_sample(handle, states, (UIntPtr)states.Length, out count);
            if (s != Status.BufferTooSmall) Check(s, "sample");
            return (int)count;
        }

        /// <summary>Asks for the kill-cam: the last `seconds` at `speed`, centred on `focus` (Native.NoEntity: the own avatar), beside the live match; answered by ReplayStarted/ReplayRefused, then ReplayEnded events.</summary>
        public void KillCam(float seconds, float speed = 1f, uint focus = Native.NoEntity) => Check(Native.inertia_kill_cam(handle, seconds, speed, focus), "kill-cam");

        /// <summary>Asks for a replay of ticks `fromTick` to `toTick` at `speed`, centred on `focus`.</summary>
        public void Replay(ulong fromTick, ulong toTick, float speed = 1f, uint focus = Native.NoEntity) => Check(Native.inertia_replay(handle, fromTick, toTick, speed, focus), "replay");

        /// <summary>Stops the replay playing, if any.</summary>
        public void CancelReplay() => Check(Native.inertia_cancel_replay(handle), "cancel replay");

        /// <summary>Draws the replay now into `states`, as Sample draws the live world; 0 before any replayed state came.</summary>
        public int ReplaySample(EntityState[] states)
        {
            UIntPtr count;
            var s = Native.inertia_replay_sample(handle, states, (UIntPtr)states.Length, out count);
            if (s != Status.BufferTooSmall) Check(s, "replay sample");
            return (int)count;
        }

        public bool TryInfo(uint id, out EntityInfo info) => Native.inertia_entity_info(handle, id, out info) == Status.Ok;

        /// <summary>A point set's points in the last sampled picture: xyz per point, and 1 per known point.</summary>
        public int PointSet(uint set, float[] positions, byte[] present)
        {
            UIntPtr count;
            var s = Native.inertia_point_set(handle, set, positions, present, (UIntPtr)present.Length, out count);
            if (s != Status.BufferTooSmall) Check(s, "point set");
            return (int)count;
        }

        public Stats Stats { get { Stats st; Native.inertia_stats(handle, out st); return st; } }

        public void Dispose()
        {
            if (handle != IntPtr.Zero)
            {
                Native.inertia_disconnect(handle);
                handle = IntPtr.Zero;
            }
        }
    }
}
