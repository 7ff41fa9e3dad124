// Joins an Inertia server from C# and prints what it sees:
//
//   mono PrintWorld.exe ADDRESS TOKEN_HEX [SECONDS]
//   mono PrintWorld.exe --dev CREDENTIALS_FILE [SECONDS]
//
// Exits 0 when it saw a body move, 1 otherwise.

using System;
using System.Threading;
using Inertia;

static class PrintWorld
{
    static byte[] FromHex(string hex)
    {
        var bytes = new byte[hex.Length / 2];
        for (int i = 0; i < bytes.Length; i++) bytes[i] = Convert.ToByte(hex.Substring(2 * i, 2), 16);
        return bytes;
    }

    static int Main(string[] args)
    {
        if (args.Length < 2)
        {
            Console.Error.WriteLine("usage: PrintWorld ADDRESS TOKEN_HEX [SECONDS] | --dev CREDENTIALS [SECONDS]");
            return 2;
        }
        int seconds = args.Length > 2 ? int.Parse(args[2]) : 3;
        using (var client = args[0] == "--dev" ? InertiaClient.ConnectDev(args[1]) : InertiaClient.Connect(args[0], FromHex(args[1]), predict: true))
        {
            var info = client.Info;
            Console.WriteLine("joined " + Native.Text(info.ServerVersion) + " (" + info.Game + ") as client " + info.ClientId + ": " + info.TickHz + " ticks/s");
            // Say hello: the sandbox's chat request (kind 1, the line's
            // length, its UTF-8), which its rules tell everyone, us included.
            client.SendMessage(new byte[] { 1, 5, (byte)'h', (byte)'e', (byte)'l', (byte)'l', (byte)'o' });
            int heard = 0;
            var states = new EntityState[20000];
            var positions = new float[3 * 16384];
            var present = new byte[16384];
            uint watched = 0;
            double first = 0, last = 0;
            int spawned = 0;
            for (int frame = 0; frame < seconds * 20; frame++)
            {
                Thread.Sleep(50);
                for (var e = client.PollEvent(); e.Kind != EventKind.None; e = client.PollEvent())
                {
                    if (e.Kind == EventKind.Spawned) spawned++;
                    // The sandbox's chat event: kind 7, the client, the line.
                    if (e.Kind == EventKind.Message && e.DataLen > 0 && e.Data[0] == 7) heard++;
                    if (e.Kind == EventKind.Disconnected) { Console.WriteLine("disconnected: " + e.Text); return 1; }
                }
                int count = Math.Min(client.Sample(states), states.Length);
                for (int i = 0; i < count && watched == 0; i++)
                {
                    EntityInfo ei;
                    if (client.TryInfo(states[i].Id, out ei) && ei.Kind == EntityKind.Dynamic)
                    {
                        watched = states[i].Id;
                        first = states[i].X + states[i].Y + states[i].Z;
                    }
                }
                for (int i = 0; i < count; i++)
                    if (states[i].Id == watched) last = states[i].X + states[i].Y + states[i].Z;
                if (frame % 20 == 19)
                {
                    Console.WriteLine("t=" + (frame + 1) / 20 + "s: " + count + " entities in the picture, " + spawned + " described");
                    for (uint id = 1; id < 100000; id++)
                    {
                        EntityInfo ei;
                        if (!client.TryInfo(id, out ei) || ei.Shape != ShapeKind.PointSet) continue;
                        int n = client.PointSet(id, positions, present);
                        int known = 0;
                        for (int i = 0; i < Math.Min(n, present.Length); i++) known += present[i];
                        Console.WriteLine("  " + (ei.Kind == EntityKind.Fluid ? "fluid " : "soft body ") + ei.Name + ": " + known + " of " + n + " points known");
                        id += ei.Points;
                    }
                    var st = client.Stats;
                    Console.WriteLine("  rtt " + st.RttMs.ToString("F1") + " ms, " + st.Kbps.ToString("F1") + " kbit/s, " + st.SnapshotsReceived + " snapshots");
                    Console.WriteLine("  inputs for tick " + st.InputTick + ": " + st.InputsOnTime + " on time, " + st.InputsLate + " late");
                }
            }
            // The kill-cam: the last second again, beside the live match.
            client.KillCam(1f);
            int replayed = 0;
            for (int frame = 0; frame < 60; frame++)
            {
                Thread.Sleep(50);
                replayed = Math.Max(replayed, Math.Min(client.ReplaySample(states), states.Length));
                var e = client.PollEvent();
                for (; e.Kind != EventKind.None; e = client.PollEvent())
                {
                    if (e.Kind == EventKind.ReplayStarted) Console.WriteLine("replay: ticks " + e.FromTick + " to " + e.ToTick);
                    if (e.Kind == EventKind.ReplayRefused) Console.WriteLine("replay refused: " + e.Text);
                    if (e.Kind == EventKind.ReplayEnded) { Console.WriteLine("replay ended: " + e.Text + ", " + replayed + " entities in its picture"); frame = 60; }
                }
            }
            bool moved = watched != 0 && last != first;
            var state = client.MatchState();
            for (uint i = 0; i < state.Length; i++)
                Console.WriteLine("match " + client.PropertyDecl(true, i).Name + " = " + state[i]);
            Console.WriteLine("heard " + heard + " chat line" + (heard == 1 ? "" : "s"));
            Console.WriteLine(moved ? "saw the world move" : "saw nothing move");
            return moved && heard > 0 ? 0 : 1;
        }
    }
}
