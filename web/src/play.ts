// The page at /play: asks the server for a session (a dev server hands one
// out), joins over WebTransport with the certificate pinned by its hash,
// decodes snapshots, and draws the world with WebGL2 and a HUD.
//
// Progress is published on `window.inertia` (snapshots received, the tick
// drawn, frames drawn, the clock), which the browser test reads.

import {
  decodeServerControl,
  encodeClientControl,
  FrameDecoder,
  MESSAGE_DATAGRAM_TAG,
  PROTOCOL_VERSION,
  type EntityDesc,
  type ServerControl,
  type Welcome,
} from "./control.js";
import { Acks, encodeInputDatagram, type PlayerInput } from "./input.js";
import {
  BUTTONS,
  decodeSandboxEvent,
  encodeSandboxInput,
  encodeSandboxRequest,
  type SandboxEvent,
} from "./sandbox.js";
import {
  decodeFootballTell,
  encodeFootballAsk,
  encodeFootballPlay,
  FOOTBALL_BUTTONS,
  footballHeadline,
  TEAMS,
  type FootballTell,
} from "./football.js";
import { meshOf, type Mesh } from "./mesh.js";
import { pointSetOf, PointSetTrack } from "./points.js";
import { propertyValue, SnapshotDecoder, type SnapshotConfig } from "./snapshot.js";
import { Renderer, type Pose } from "./render.js";

interface Session {
  url: string;
  cert_hash: string;
  token: string;
  client_id: number;
}

/** What the page has done, for people and for tests. */
export interface Progress {
  state: "connecting" | "joined" | "closed" | "failed";
  error: string | null;
  /** The game the server runs, as its welcome names it. */
  game: string;
  /** The game's headline (football's score and clock), if it has one. */
  headline: string | null;
  snapshots: number;
  tick: number;
  paused: boolean;
  timeScale: number;
  entities: number;
  /** Soft bodies and fluids described, and how many of their points a
   * snapshot has placed. */
  pointSets: number;
  points: number;
  frames: number;
  /** The game's messages received, and the last few as lines. */
  messages: number;
  log: string[];
  /** The game's match properties by name, as of the newest snapshot. */
  matchState: Record<string, number>;
}

const progress: Progress = {
  state: "connecting",
  error: null,
  game: "",
  headline: null,
  snapshots: 0,
  tick: 0,
  paused: false,
  timeScale: 1,
  entities: 0,
  pointSets: 0,
  points: 0,
  frames: 0,
  messages: 0,
  log: [],
  matchState: {},
};

/** A sandbox event as a line for the HUD. */
function eventLine(e: SandboxEvent): string {
  switch (e.kind) {
    case "joined":
      return `client ${e.client.toString(16)} joined`;
    case "left":
      return `client ${e.client.toString(16)} left`;
    case "respawned":
      return `client ${e.client.toString(16)} respawned`;
    case "jumped":
      return `#${e.avatar} jumped`;
    case "pushed":
      return `#${e.avatar} pushed #${e.target}`;
    case "removed":
      return `#${e.entity} removed (${e.reason.replaceAll("_", " ")})`;
    case "chat":
      return `${e.client.toString(16)}: ${e.text}`;
  }
}

/** A football message as a line for the HUD. */
function tellLine(t: FootballTell): string {
  const team = (code: number): string => TEAMS[code] ?? "?";
  switch (t.kind) {
    case "joined":
      return `client ${t.client.toString(16)} plays for ${team(t.team)}`;
    case "kickoff":
      return `kickoff, ${team(t.team)} to kick`;
    case "goal":
      return `goal for ${team(t.team)}! ${t.score[0]}–${t.score[1]}`;
    case "over":
      return `${team(t.winner)} wins ${t.score[0]}–${t.score[1]}`;
    case "said":
      return `${t.client.toString(16)}: ${t.text}`;
  }
}

/** The game the server runs, as its welcome names it: the page plays the
 * sandbox and football, and watches any other. */
let game = "";

/** A game message arrived, read as the game's. */
function onMessage(bytes: Uint8Array): void {
  progress.messages++;
  let line: string;
  try {
    if (game === "football") {
      line = tellLine(decodeFootballTell(bytes));
    } else if (game === "sandbox") {
      line = eventLine(decodeSandboxEvent(bytes));
    } else {
      line = `a message of ${bytes.length} bytes`;
    }
  } catch {
    line = `a message of ${bytes.length} bytes this page cannot read`;
  }
  progress.log.push(line);
  progress.log.splice(0, Math.max(0, progress.log.length - 5));
}
(window as unknown as { inertia: Progress }).inertia = progress;

function bytesOfHex(hex: string): Uint8Array<ArrayBuffer> {
  return Uint8Array.from(hex.match(/../g) ?? [], (b) => parseInt(b, 16));
}

/** One entity's last two poses, with their arrival times (ms). */
interface Track {
  desc: EntityDesc;
  mesh: Mesh;
  before: Pose;
  after: Pose;
  at: number;
}

class World {
  readonly tracks = new Map<number, Track>();
  /** Soft bodies and fluids, by their entity id. */
  readonly sets = new Map<number, PointSetTrack>();
  /** Snapshot interval seen lately, ms. */
  interval = 33;
  private lastArrival = 0;

  describe(desc: EntityDesc): void {
    if (pointSetOf(desc)) {
      this.sets.set(desc.id, new PointSetTrack(desc));
      return;
    }
    const pose: Pose = { position: desc.position, rotation: desc.rotation };
    this.tracks.set(desc.id, { desc, mesh: meshOf(desc.shape), before: pose, after: pose, at: 0 });
  }

  forget(id: number): void {
    if (this.tracks.delete(id) || this.sets.delete(id)) {
      return;
    }
    const [set, i] = this.pointOf(id);
    set?.hide(i);
  }

  /** The set entity `id` is a point of, and its index there. */
  pointOf(id: number): [PointSetTrack | undefined, number] {
    for (const set of this.sets.values()) {
      const i = set.indexOf(id);
      if (i >= 0) {
        return [set, i];
      }
    }
    return [undefined, -1];
  }

  arrived(now: number): void {
    if (this.lastArrival > 0) {
      const gap = now - this.lastArrival;
      this.interval += (Math.min(Math.max(gap, 5), 200) - this.interval) * 0.1;
    }
    this.lastArrival = now;
  }

  move(id: number, pose: Pose, now: number): void {
    const t = this.tracks.get(id);
    if (!t) {
      const [set, i] = this.pointOf(id);
      set?.move(i, pose.position, now, this.interval);
      return;
    }
    t.before = this.poseAt(t, now);
    t.after = pose;
    t.at = now;
  }

  /** Where `t` is drawn at `now`: from its previous pose to its newest
   * over one snapshot interval after the newest arrived. */
  poseAt(t: Track, now: number): Pose {
    const u = Math.min(Math.max((now - t.at) / this.interval, 0), 1);
    return lerpPose(t.before, t.after, u);
  }
}

function lerpPose(a: Pose, b: Pose, u: number): Pose {
  const p = a.position.map((x, i) => x + ((b.position[i] ?? x) - x) * u) as [number, number, number];
  // Normalised linear blend along the shorter arc: enough between two
  // snapshots a frame or two apart.
  const dot = a.rotation.reduce((s, x, i) => s + x * (b.rotation[i] ?? 0), 0);
  const sign = dot < 0 ? -1 : 1;
  const q = a.rotation.map((x, i) => x + (sign * (b.rotation[i] ?? 0) - x) * u);
  const n = Math.hypot(...q) || 1;
  return { position: p, rotation: q.map((x) => x / n) as [number, number, number, number] };
}

function snapshotConfig(w: Welcome): SnapshotConfig {
  return {
    grid: { resolution: w.position_resolution, bound: w.position_bound },
    rotationBits: w.snapshot.rotation_bits,
    velocities: w.snapshot.velocity_resolution !== null,
    velocityGrid: { resolution: w.snapshot.velocity_resolution ?? 0.01, bound: w.snapshot.velocity_bound },
    maxDatagram: w.snapshot.max_datagram,
  };
}

function setStatus(text: string): void {
  const el = document.getElementById("status");
  if (el) {
    el.textContent = text;
  }
}

function showFigures(rows: [string, string][]): void {
  const table = document.getElementById("figures");
  if (!table) {
    return;
  }
  table.innerHTML = rows.map(([k, v]) => `<tr><td>${k}</td><td>${v}</td></tr>`).join("");
}

async function main(): Promise<void> {
  const answer = await fetch("/play/session", { cache: "no-store" });
  if (!answer.ok) {
    throw new Error(`no session: ${answer.status} ${await answer.text()}`);
  }
  const session = (await answer.json()) as Session;
  const transport = new WebTransport(session.url, {
    serverCertificateHashes: [{ algorithm: "sha-256", value: bytesOfHex(session.cert_hash) }],
  });
  await transport.ready;
  const stream = await transport.createBidirectionalStream();
  const control = stream.writable.getWriter();
  await control.write(encodeClientControl({ Hello: { version: PROTOCOL_VERSION, token: bytesOfHex(session.token) } }));

  const world = new World();
  const frames = new FrameDecoder();
  const reader = stream.readable.getReader();
  let welcome: Welcome | null = null;
  // Inputs are applied on the tick they are stamped with: each is stamped
  // with the tick the server will be at when it arrives (the newest
  // snapshot's tick, a round trip and a margin ahead), and the margin
  // follows the server's reports of how early the inputs came
  // (client-sdk/src/lead.rs does the same for the Rust SDK).
  const lead = { margin: 2, stamped: 0n };
  const handle = (msg: ServerControl): void => {
    if ("InputTiming" in msg) {
      const least = msg.InputTiming.min_lead;
      if (least !== null && least < 1) {
        lead.margin = Math.min(30, lead.margin + 1 - least);
      } else if (least !== null && least > 3) {
        lead.margin = Math.max(0, lead.margin - 0.5 * (least - 3));
      }
    } else if ("Welcome" in msg) {
      welcome = msg.Welcome;
      game = welcome.game;
      progress.game = game;
    } else if ("Spawn" in msg) {
      world.describe(msg.Spawn);
    } else if ("Despawn" in msg) {
      world.forget(msg.Despawn.id);
    } else if ("Message" in msg) {
      onMessage(Uint8Array.from(msg.Message));
    } else if ("Refused" in msg) {
      throw new Error(`refused: ${JSON.stringify(msg.Refused)}`);
    } else if ("Goodbye" in msg) {
      progress.state = "closed";
      setStatus(`the server said goodbye: ${JSON.stringify(msg.Goodbye)}`);
    }
  };
  const readControl = async (): Promise<void> => {
    for (;;) {
      const { value, done } = await reader.read();
      if (done) {
        return;
      }
      frames.push(value);
      for (let payload = frames.next(); payload; payload = frames.next()) {
        handle(decodeServerControl(payload));
      }
    }
  };
  // The welcome first: nothing decodes before it.
  while (!welcome) {
    const { value, done } = await reader.read();
    if (done) {
      throw new Error("the server closed the control stream before its welcome");
    }
    frames.push(value);
    for (let payload = frames.next(); payload; payload = frames.next()) {
      handle(decodeServerControl(payload));
    }
  }
  const joined: Welcome = welcome;
  void readControl().catch((e: unknown) => fail(e));
  progress.state = "joined";
  setStatus("");

  const decoder = new SnapshotDecoder(snapshotConfig(joined), joined.properties);
  const acks = new Acks();
  let received = 0;
  let bytesWindow: [number, number][] = [];
  const datagrams = transport.datagrams.readable.getReader();
  const readSnapshots = async (): Promise<void> => {
    for (;;) {
      const { value, done } = await datagrams.read();
      if (done) {
        return;
      }
      const now = performance.now();
      bytesWindow.push([now, value.length]);
      if (value[0] === MESSAGE_DATAGRAM_TAG) {
        onMessage(value.subarray(1));
        continue;
      }
      try {
        const snap = decoder.decode(value);
        acks.received(snap.sequence);
        received++;
        progress.snapshots = received;
        progress.paused = snap.paused;
        progress.timeScale = snap.timeScale;
        if (Number(snap.tick) >= progress.tick) {
          progress.tick = Number(snap.tick);
          world.arrived(now);
          // The game's match state as of the newest snapshot, by name.
          const raw = decoder.matchState(snap.sequence);
          joined.properties.match_state.forEach((d, i) => {
            progress.matchState[d.name] = propertyValue(d.kind, raw?.[i] ?? 0n);
          });
        }
        for (const id of snap.removed) {
          world.forget(id);
        }
        for (const e of snap.updated) {
          world.move(e.id, { position: e.position, rotation: e.rotation }, now);
        }
      } catch {
        // A datagram that does not decode (its baseline was lost): the
        // next ones will.
      }
    }
  };
  void readSnapshots().catch((e: unknown) => fail(e));

  // The round trip, where the browser reports it (WebTransport's stats).
  let rttMs: number | null = null;
  const stats = (transport as unknown as { getStats?: () => Promise<{ smoothedRtt?: number }> }).getStats;
  if (stats) {
    setInterval(() => {
      stats
        .call(transport)
        .then((s) => {
          rttMs = typeof s.smoothedRtt === "number" ? s.smoothedRtt : null;
        })
        .catch(() => {});
    }, 1000);
  }

  // Inputs at the tick rate, with the acknowledgements the server codes
  // against; the last few repeated.
  const sender = transport.datagrams.writable.getWriter();
  const recent: PlayerInput[] = [];
  let sequence = 0;
  const keys = new Set<string>();
  // The game's requests: in the sandbox R respawns, in football T
  // switches team; Enter says something in both.
  const request = (bytes: Uint8Array): void => {
    void control.write(encodeClientControl({ Message: bytes })).catch(() => {});
  };
  addEventListener("keydown", (e) => {
    if (e.repeat) {
      return;
    }
    if (e.key === "r" && game === "sandbox") {
      request(encodeSandboxRequest({ kind: "respawn" }));
    } else if (e.key === "t" && game === "football") {
      request(encodeFootballAsk({ kind: "switch_team" }));
    } else if (e.key === "Enter") {
      const text = prompt("say") ?? "";
      if (text) {
        try {
          if (game === "football") {
            request(encodeFootballAsk({ kind: "say", text }));
          } else if (game === "sandbox") {
            request(encodeSandboxRequest({ kind: "chat", text }));
          }
        } catch (err) {
          setStatus(err instanceof Error ? err.message : String(err));
        }
      }
    }
  });
  addEventListener("keydown", (e) => keys.add(e.key.toLowerCase()));
  addEventListener("keyup", (e) => keys.delete(e.key.toLowerCase()));
  /** This tick's input, the game's own: the sandbox walks along the
   * world's axes; football runs and kicks along the camera's view (Space
   * jumps, E kicks, Shift lobs). */
  const play = (): Uint8Array | null => {
    const x = (keys.has("d") ? 1 : 0) - (keys.has("a") ? 1 : 0);
    const z = (keys.has("s") ? 1 : 0) - (keys.has("w") ? 1 : 0);
    if (game === "sandbox") {
      return encodeSandboxInput({ movement: [x, z], yaw: 0, buttons: keys.has(" ") ? BUTTONS.JUMP : 0 });
    }
    if (game !== "football") {
      return null;
    }
    // Ahead is away from the camera; W runs ahead, D to its right.
    const yaw = renderer.camera.yaw + Math.PI;
    const ahead: [number, number] = [Math.sin(yaw), Math.cos(yaw)];
    const side: [number, number] = [-ahead[1], ahead[0]];
    let stick: [number, number] = [ahead[0] * -z + side[0] * x, ahead[1] * -z + side[1] * x];
    const len = Math.hypot(stick[0], stick[1]);
    if (len > 1) {
      stick = [stick[0] / len, stick[1] / len];
    }
    const buttons = (keys.has(" ") ? FOOTBALL_BUTTONS.JUMP : 0) | (keys.has("e") ? FOOTBALL_BUTTONS.KICK : 0);
    return encodeFootballPlay({ stick, yaw, pitch: keys.has("shift") ? 40 : 10, buttons });
  };
  setInterval(() => {
    const payload = play();
    if (payload === null) {
      return;
    }
    sequence = (sequence + 1) >>> 0;
    const ahead = Math.ceil(((rttMs ?? 0) / 1000) * joined.tick_hz + lead.margin);
    const wanted = BigInt(progress.tick) + BigInt(ahead);
    lead.stamped = wanted > lead.stamped ? wanted : lead.stamped;
    // The page draws the newest snapshot: what the player saw is that
    // snapshot's tick, this far behind the input's.
    const viewBehind = Math.min(255, Number(lead.stamped - BigInt(progress.tick)));
    recent.unshift({
      sequence,
      tick: lead.stamped,
      payload,
      viewBehind,
    });
    recent.length = Math.min(recent.length, 8);
    const { ack, ackBits } = acks.get();
    void sender.write(encodeInputDatagram({ ack, ackBits, inputs: recent })).catch(() => {});
  }, 1000 / joined.tick_hz);

  const canvas = document.getElementById("world") as HTMLCanvasElement;
  const renderer = new Renderer(canvas);
  let drag: [number, number] | null = null;
  canvas.addEventListener("pointerdown", (e) => (drag = [e.clientX, e.clientY]));
  addEventListener("pointerup", () => (drag = null));
  addEventListener("pointermove", (e) => {
    if (drag) {
      renderer.camera.orbit(e.clientX - drag[0], e.clientY - drag[1]);
      drag = [e.clientX, e.clientY];
    }
  });
  canvas.addEventListener("wheel", (e) => renderer.camera.zoom(-Math.sign(e.deltaY)), { passive: true });

  const frame = (): void => {
    const now = performance.now();
    const items = [...world.tracks.values()].map((t) => ({
      id: t.desc.id,
      mesh: t.mesh,
      color: t.desc.color,
      kind: t.desc.kind,
      pose: world.poseAt(t, now),
    }));
    const origin: Pose = { position: [0, 0, 0], rotation: [0, 0, 0, 1] };
    for (const set of world.sets.values()) {
      items.push({
        id: set.desc.id,
        mesh: set.mesh(now, world.interval),
        color: set.desc.color,
        kind: set.desc.kind,
        pose: origin,
      });
    }
    renderer.draw(items);
    progress.frames++;
    progress.entities = items.length;
    progress.pointSets = world.sets.size;
    progress.points = [...world.sets.values()].reduce((n, set) => n + set.present.reduce((k, p) => k + p, 0), 0);
    bytesWindow = bytesWindow.filter(([t]) => now - t < 1000);
    const kbps = (bytesWindow.reduce((s, [, n]) => s + n, 0) * 8) / 1000;
    const clock = progress.paused
      ? "paused"
      : progress.timeScale < 0
        ? `reverse ×${-progress.timeScale}`
        : `running ×${progress.timeScale}`;
    // Loss: the share of the 32 sequence numbers before the newest that
    // did not arrive (once 33 have been sent).
    const { ackBits } = acks.get();
    let seen = 0;
    for (let k = 0; k < 32; k++) {
      seen += (ackBits >>> k) & 1;
    }
    const loss = received > 32 ? ((32 - seen) / 32) * 100 : 0;
    const m = progress.matchState;
    progress.headline =
      game === "football"
        ? footballHeadline([m.score_red ?? 0, m.score_blue ?? 0], m.clock ?? 0, m.phase ?? 0, m.winner ?? 0)
        : null;
    showFigures([
      // The game's headline: football's score and clock.
      ...(progress.headline === null ? [] : [["score", progress.headline] as [string, string]]),
      ["server", new URL(session.url).host],
      ["client", session.client_id.toString(16)],
      ["tick", progress.tick.toString()],
      ["sim time", `${(progress.tick / joined.tick_hz).toFixed(2)} s`],
      ["clock", clock],
      ["entities", items.length.toString()],
      ["snapshots", received.toString()],
      ["RTT", rttMs === null ? "—" : `${rttMs.toFixed(1)} ms`],
      ["received", `${kbps.toFixed(0)} kbit/s`],
      ["buffer", `${world.interval.toFixed(0)} ms`],
      ["loss", `${loss.toFixed(1)} %`],
      ["events", progress.log.length ? progress.log.join(" · ") : "—"],
      // A line per match property (the score, the clock).
      ...Object.entries(progress.matchState).map(([name, v]): [string, string] => [
        name,
        Number.isInteger(v) ? v.toString() : v.toFixed(2),
      ]),
    ]);
    if (progress.state === "joined") {
      requestAnimationFrame(frame);
    }
  };
  requestAnimationFrame(frame);
  void transport.closed
    .then(() => {
      progress.state = "closed";
      setStatus("disconnected");
    })
    .catch((e: unknown) => fail(e));
}

function fail(e: unknown): void {
  progress.state = "failed";
  progress.error = e instanceof Error ? e.message : String(e);
  setStatus(`failed: ${progress.error}`);
}

main().catch(fail);
