// Football's input and messages, as `games/football/src/input.rs` and
// `games/football/src/messages.rs` lay them out; checked against the golden
// vectors the Rust encoders write (`games/football/tests/vectors/football.json`).

/** Football's buttons: jump 1, kick 2. */
export const FOOTBALL_BUTTONS = { JUMP: 1, KICK: 2, ALL: 3 } as const;

/** Bytes of a football play. */
export const FOOTBALL_INPUT_BYTES = 6;

/** The longest chat line, bytes of UTF-8. */
export const MAX_LINE = 100;

/** Teams by code: red 1 (attacks +x), blue 2. */
export const TEAMS: Record<number, string> = { 1: "red", 2: "blue" };

/** What a football player wants for one tick. */
export interface FootballPlay {
  /** The stick (x, z), each in [−1, 1]. */
  stick: [number, number];
  /** Facing about +y, rad (0 faces +z). */
  yaw: number;
  /** How high a kick goes, degrees above the grass. */
  pitch: number;
  /** Held buttons ({@link FOOTBALL_BUTTONS}; undefined bits are dropped). */
  buttons: number;
}

/** Rounds half away from zero, as Rust's `f64::round`. */
function round(x: number): number {
  return Math.sign(x) * Math.round(Math.abs(x));
}

function axis(v: number): number {
  return Number.isNaN(v) ? 0 : round(Math.min(1, Math.max(-1, v)) * 127);
}

/** A play's 6 bytes, as `Play::new` and its encoder write them. */
export function encodeFootballPlay(play: FootballPlay): Uint8Array {
  const turns = Number.isFinite(play.yaw) ? play.yaw / (2 * Math.PI) : 0;
  const yaw = round((turns - Math.floor(turns)) * 65536) % 65536;
  const pitch = Number.isNaN(play.pitch) ? 0 : round(Math.min(90, Math.max(-90, play.pitch)));
  const out = new Uint8Array(FOOTBALL_INPUT_BYTES);
  out[0] = axis(play.stick[0]) & 0xff;
  out[1] = axis(play.stick[1]) & 0xff;
  out[2] = yaw & 0xff;
  out[3] = yaw >> 8;
  out[4] = pitch & 0xff;
  out[5] = play.buttons & FOOTBALL_BUTTONS.ALL;
  return out;
}

/** What the rules tell the players. */
export type FootballTell =
  | { kind: "joined"; client: bigint; team: number }
  | { kind: "kickoff"; team: number }
  | { kind: "goal"; tick: bigint; team: number; scorer: bigint | null; score: [number, number] }
  | { kind: "over"; winner: number; score: [number, number] }
  | { kind: "said"; client: bigint; text: string };

/** What a player may ask of the rules. */
export type FootballAsk = { kind: "say"; text: string } | { kind: "switch_team" };

/** Bytes football's decoder refuses. */
export class FootballMessageError extends Error {}

class Reader {
  private at = 0;
  constructor(private readonly bytes: Uint8Array) {}

  u8(): number {
    const b = this.bytes[this.at];
    if (b === undefined) throw new FootballMessageError("the message ends early");
    this.at++;
    return b;
  }

  u64(): bigint {
    let v = 0n;
    for (let i = 0n; i < 8n; i++) {
      v |= BigInt(this.u8()) << (8n * i);
    }
    return v;
  }

  team(): number {
    const t = this.u8();
    if (!(t in TEAMS)) throw new FootballMessageError(`team ${t}`);
    return t;
  }

  line(): string {
    const n = this.u8();
    if (n > MAX_LINE) throw new FootballMessageError(`a line of ${n} bytes`);
    if (this.at + n > this.bytes.length) throw new FootballMessageError("the message ends early");
    const raw = this.bytes.subarray(this.at, this.at + n);
    this.at += n;
    try {
      return new TextDecoder("utf-8", { fatal: true }).decode(raw);
    } catch {
      throw new FootballMessageError("a line that is not UTF-8");
    }
  }

  done(): void {
    if (this.at !== this.bytes.length) throw new FootballMessageError("bytes after the message");
  }
}

/** A message of the rules' from its bytes; throws a {@link FootballMessageError}
 * for bytes the Rust encoder would not write. */
export function decodeFootballTell(bytes: Uint8Array): FootballTell {
  const r = new Reader(bytes);
  let t: FootballTell;
  switch (r.u8()) {
    case 1:
      t = { kind: "joined", client: r.u64(), team: r.team() };
      break;
    case 2:
      t = { kind: "kickoff", team: r.team() };
      break;
    case 3: {
      const tick = r.u64();
      const team = r.team();
      const flag = r.u8();
      if (flag > 1) throw new FootballMessageError(`a scorer flag of ${flag}`);
      const scorer = flag === 1 ? r.u64() : null;
      t = { kind: "goal", tick, team, scorer, score: [r.u8(), r.u8()] };
      break;
    }
    case 4:
      t = { kind: "over", winner: r.team(), score: [r.u8(), r.u8()] };
      break;
    case 5:
      t = { kind: "said", client: r.u64(), text: r.line() };
      break;
    default:
      throw new FootballMessageError("a message kind football does not define");
  }
  r.done();
  return t;
}

/** An ask's bytes, as the Rust encoder writes them (a line past
 * {@link MAX_LINE} bytes is cut at a character boundary). */
export function encodeFootballAsk(ask: FootballAsk): Uint8Array {
  if (ask.kind === "switch_team") {
    return Uint8Array.of(2);
  }
  let text = new TextEncoder().encode(ask.text);
  if (text.length > MAX_LINE) {
    let end = MAX_LINE;
    // Back to the start of a character: never inside a UTF-8 sequence.
    while (end > 0 && (text[end]! & 0xc0) === 0x80) {
      end--;
    }
    text = text.subarray(0, end);
  }
  return Uint8Array.from([1, text.length, ...text]);
}

/** `red 1 – 0 blue · 2:31 · playing`, from the match's properties. */
export function footballHeadline(
  score: [number, number],
  clock: number,
  phase: number,
  winner: number,
): string {
  const seconds = Math.max(0, Math.floor(clock));
  const state =
    phase === 3 && winner in TEAMS
      ? `${TEAMS[winner]} wins`
      : phase === 0
        ? "waiting for a player on each team"
        : phase === 1
          ? "kickoff"
          : seconds === 0
            ? "golden goal"
            : "playing";
  const mm = Math.floor(seconds / 60);
  const ss = String(seconds % 60).padStart(2, "0");
  return `red ${score[0]} – ${score[1]} blue · ${mm}:${ss} · ${state}`;
}
