// The sandbox game's input, as `sandbox/src/input.rs` lays it out: a stick,
// a facing angle and two buttons in 36 bits (5 bytes, least significant
// bit first), the payload of every input the page sends the stock server.

/** Defined buttons: jump 1, push 2. */
export const BUTTONS = { JUMP: 1, PUSH: 2, ALL: 3 } as const;

/** Bytes of a sandbox input. */
export const SANDBOX_INPUT_BYTES = 5;

const MOVEMENT_STEPS = 127;
const YAW_BITS = 12;

/** What a sandbox player wants for one tick. */
export interface SandboxInput {
  /** Movement in the horizontal plane (x, z), each in [−1, 1]. */
  movement: [number, number];
  /** Facing angle about +Y, rad. */
  yaw: number;
  /** Held buttons ({@link BUTTONS}; undefined bits are dropped). */
  buttons: number;
}

/** A movement axis on the grid (NaN as 0, clamped to [−1, 1]). */
function movementIndex(x: number): number {
  const f = Math.fround(x);
  const c = Number.isNaN(f) ? 0 : Math.min(1, Math.max(-1, f));
  return Math.round((c + 1) * MOVEMENT_STEPS);
}

/** The yaw in 4096ths of a turn (not finite as 0). */
function yawIndex(yaw: number): number {
  const f = Math.fround(yaw);
  if (!Number.isFinite(f)) {
    return 0;
  }
  const turns = f / (2 * Math.PI);
  const frac = turns - Math.floor(turns);
  return Math.round(frac * 2 ** YAW_BITS) % 2 ** YAW_BITS;
}

/** The input's 5 bytes, as the Rust encoder writes them. */
export function encodeSandboxInput(input: SandboxInput): Uint8Array {
  const bits =
    BigInt(movementIndex(input.movement[0])) |
    (BigInt(movementIndex(input.movement[1])) << 8n) |
    (BigInt(yawIndex(input.yaw)) << 16n) |
    (BigInt(input.buttons & BUTTONS.ALL) << 28n);
  const out = new Uint8Array(SANDBOX_INPUT_BYTES);
  for (let i = 0; i < SANDBOX_INPUT_BYTES; i++) {
    out[i] = Number((bits >> BigInt(8 * i)) & 0xffn);
  }
  return out;
}

// ---- messages (sandbox/src/event.rs, sandbox/src/request.rs) ----

/** The longest chat line, bytes of UTF-8. */
export const MAX_CHAT_BYTES = 200;

/** Something that happened in the sandbox, as its rules tell every client. */
export type SandboxEvent =
  | { kind: "joined"; client: bigint; avatar: number }
  | { kind: "left"; client: bigint }
  | { kind: "respawned"; client: bigint; avatar: number }
  | { kind: "jumped"; avatar: number }
  | { kind: "pushed"; avatar: number; target: number; impulse: [number, number, number] }
  | { kind: "removed"; entity: number; reason: "out_of_bounds" | "quarantined" | "despawned" }
  | { kind: "chat"; client: bigint; text: string };

/** What a sandbox player may ask of the rules. */
export type SandboxRequest = { kind: "chat"; text: string } | { kind: "respawn" };

/** Bytes the sandbox's decoder refuses. */
export class SandboxMessageError extends Error {}

class MessageReader {
  private at = 0;
  constructor(private readonly bytes: Uint8Array) {}

  u8(): number {
    const b = this.bytes[this.at];
    if (b === undefined) throw new SandboxMessageError("the message ends early");
    this.at++;
    return b;
  }

  /** A canonical LEB128 varint of at most `bits` bits. */
  varint(bits: number): bigint {
    let v = 0n;
    for (let shift = 0n; ; shift += 7n) {
      if (shift >= 70n) throw new SandboxMessageError("a varint past 10 bytes");
      const b = this.u8();
      v |= BigInt(b & 0x7f) << shift;
      if ((b & 0x80) === 0) {
        if (b === 0 && shift > 0n) throw new SandboxMessageError("a varint spelled long");
        break;
      }
    }
    if (v >> BigInt(bits) !== 0n) throw new SandboxMessageError(`a varint past ${bits} bits`);
    return v;
  }

  id(): number {
    return Number(this.varint(32));
  }

  f32(): number {
    if (this.at + 4 > this.bytes.length) throw new SandboxMessageError("the message ends early");
    const v = new DataView(this.bytes.buffer, this.bytes.byteOffset + this.at, 4).getFloat32(0, true);
    this.at += 4;
    return v;
  }

  text(): string {
    const n = Number(this.varint(32));
    if (n > MAX_CHAT_BYTES) throw new SandboxMessageError(`a chat line of ${n} bytes`);
    if (this.at + n > this.bytes.length) throw new SandboxMessageError("the message ends early");
    const raw = this.bytes.subarray(this.at, this.at + n);
    this.at += n;
    try {
      return new TextDecoder("utf-8", { fatal: true }).decode(raw);
    } catch {
      throw new SandboxMessageError("a chat line that is not UTF-8");
    }
  }

  done(): void {
    if (this.at !== this.bytes.length) throw new SandboxMessageError("bytes after the message");
  }
}

const REASONS = ["out_of_bounds", "quarantined", "despawned"] as const;

/** A sandbox event from a message's bytes; throws a {@link SandboxMessageError}
 * for bytes the Rust encoder would not write. */
export function decodeSandboxEvent(bytes: Uint8Array): SandboxEvent {
  const r = new MessageReader(bytes);
  let e: SandboxEvent;
  switch (r.u8()) {
    case 1:
      e = { kind: "joined", client: r.varint(64), avatar: r.id() };
      break;
    case 2:
      e = { kind: "left", client: r.varint(64) };
      break;
    case 3:
      e = { kind: "respawned", client: r.varint(64), avatar: r.id() };
      break;
    case 4:
      e = { kind: "jumped", avatar: r.id() };
      break;
    case 5:
      e = { kind: "pushed", avatar: r.id(), target: r.id(), impulse: [r.f32(), r.f32(), r.f32()] };
      break;
    case 6: {
      const entity = r.id();
      const reason = REASONS[r.u8()];
      if (reason === undefined) throw new SandboxMessageError("an unknown removal reason");
      e = { kind: "removed", entity, reason };
      break;
    }
    case 7:
      e = { kind: "chat", client: r.varint(64), text: r.text() };
      break;
    default:
      throw new SandboxMessageError("an event kind the sandbox does not define");
  }
  r.done();
  return e;
}

function pushVarint(out: number[], v: number): void {
  do {
    const b = v % 128;
    v = Math.floor(v / 128);
    out.push(v > 0 ? b | 0x80 : b);
  } while (v > 0);
}

/** A request's bytes, as the Rust encoder writes them; throws a `RangeError`
 * for a chat line past {@link MAX_CHAT_BYTES}. */
export function encodeSandboxRequest(request: SandboxRequest): Uint8Array {
  if (request.kind === "respawn") {
    return Uint8Array.of(2);
  }
  const text = new TextEncoder().encode(request.text);
  if (text.length > MAX_CHAT_BYTES) {
    throw new RangeError(`a chat line of ${text.length} bytes, the most is ${MAX_CHAT_BYTES}`);
  }
  const out = [1];
  pushVarint(out, text.length);
  return Uint8Array.from([...out, ...text]);
}
