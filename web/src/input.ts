// The client's datagram, as `protocol/src/input/mod.rs` lays it out: which
// snapshots arrived (the server codes the next ones against them) and the
// newest inputs, each repeated in the next few datagrams against loss.
// What an input says is the game's: its payload, the game's bytes (the
// sandbox's are made by `sandbox.ts`).

import { BitWriter } from "./bits.js";

/** The first byte of every input datagram. */
export const INPUT_DATAGRAM_TAG = 0x49;
/** The most inputs one datagram carries. */
export const MAX_REDUNDANT_INPUTS = 8;
/** The most bytes one input's payload may hold. */
export const MAX_INPUT_BYTES = 64;
/** Steps of the view offset per tick: it travels in 1/16 tick. */
export const VIEW_STEPS_PER_TICK = 16;
/** The most steps of the view offset the wire carries (4095/16 ticks). */
export const MAX_VIEW_BEHIND_STEPS = 4095;

/** One tick's worth of a player's intent. */
export interface PlayerInput {
  /** Increases by one per input (wraps at 2^32). */
  sequence: number;
  /** The server tick it is meant for. */
  tick: bigint;
  /** The game's input, as its bytes (at most {@link MAX_INPUT_BYTES}; one
   * size in every input of a datagram). */
  payload: Uint8Array;
  /** How far behind `tick` the world the player saw was, ticks (≥ 0; the
   * server answers its shots against the world at `tick − viewBehind`).
   * Sent in 1/16 tick, at most 4095/16; NaN and negative as 0. */
  viewBehind: number;
}

export interface InputDatagram {
  /** The newest snapshot sequence received, if any yet. */
  ack: number | null;
  /** Bit i: snapshot `ack − 1 − i` (wrapping) received too. */
  ackBits: number;
  /** The newest inputs, newest first, at most {@link MAX_REDUNDANT_INPUTS}. */
  inputs: PlayerInput[];
}

/** The view offset in sixteenths of a tick (NaN, negative as 0; capped). */
function viewIndex(behind: number): number {
  const f = Math.fround(behind);
  if (Number.isNaN(f) || f <= 0) {
    return 0;
  }
  return Math.min(Math.round(f * VIEW_STEPS_PER_TICK), MAX_VIEW_BEHIND_STEPS);
}

function writeVarint(w: BitWriter, value: bigint): void {
  let v = value;
  for (;;) {
    const group = Number(v & 0x7fn);
    v >>= 7n;
    w.writeBool(v !== 0n);
    w.write(group, 7);
    if (v === 0n) {
      return;
    }
  }
}

function zigzag(v: bigint): bigint {
  return v >= 0n ? v << 1n : ((-v) << 1n) - 1n;
}

function writePayload(w: BitWriter, payload: Uint8Array): void {
  for (const b of payload) {
    w.write(b, 8);
  }
}

function samePayload(a: Uint8Array, b: Uint8Array): boolean {
  return a.length === b.length && a.every((x, i) => x === b[i]);
}

/** The datagram's bytes. Throws a `RangeError` for what the layout cannot
 * carry: too many inputs, ack bits without an ack, payloads too long or of
 * different sizes, a sequence repeated. */
export function encodeInputDatagram(d: InputDatagram): Uint8Array {
  if (d.inputs.length > MAX_REDUNDANT_INPUTS) {
    throw new RangeError(`${d.inputs.length} inputs, the most is ${MAX_REDUNDANT_INPUTS}`);
  }
  const w = new BitWriter();
  w.write(INPUT_DATAGRAM_TAG, 8);
  if (d.ack === null) {
    if (d.ackBits !== 0) {
      throw new RangeError("ack bits without an ack");
    }
    w.writeBool(false);
  } else {
    w.writeBool(true);
    w.write(d.ack, 16);
    w.write(d.ackBits >>> 0, 32);
  }
  w.write(d.inputs.length, 4);
  const size = d.inputs[0]?.payload.length ?? 0;
  if (size > MAX_INPUT_BYTES) {
    throw new RangeError(`payloads of ${size} bytes, the most is ${MAX_INPUT_BYTES}`);
  }
  w.write(size, 7);
  let prev: PlayerInput | null = null;
  for (const input of d.inputs) {
    if (input.payload.length !== size) {
      throw new RangeError(`a payload of ${input.payload.length} bytes among ones of ${size}`);
    }
    if (prev === null) {
      w.write(input.sequence >>> 0, 32);
      writeVarint(w, input.tick);
      writePayload(w, input.payload);
    } else {
      const step = (prev.sequence - input.sequence) >>> 0;
      if (step === 0) {
        throw new RangeError("a sequence repeated");
      }
      if (step === 1) {
        w.writeBool(true);
      } else {
        w.writeBool(false);
        writeVarint(w, BigInt(step - 2));
      }
      // Ticks wrap at 2^64, as the Rust encoder's do.
      const raw = BigInt.asIntN(64, input.tick - prev.tick);
      if (raw === -1n) {
        w.writeBool(true);
      } else {
        w.writeBool(false);
        writeVarint(w, zigzag(raw));
      }
      const same = samePayload(input.payload, prev.payload);
      w.writeBool(same);
      if (!same) {
        writePayload(w, input.payload);
      }
    }
    writeVarint(w, BigInt(viewIndex(input.viewBehind)));
    prev = input;
  }
  return w.finish();
}

/** Which snapshots arrived, as the datagram tells the server: the newest
 * sequence number and a bit for each of the 32 before it. */
export class Acks {
  private newest: number | null = null;
  private bits = 0;

  /** A snapshot with sequence `seq` (16-bit, wrapping) arrived. */
  received(seq: number): void {
    if (this.newest === null) {
      this.newest = seq;
      this.bits = 0;
      return;
    }
    const ahead = (seq - this.newest) & 0xffff;
    if (ahead === 0) {
      return;
    }
    if (ahead < 0x8000) {
      // Newer: shift the window on, the old newest becoming bit ahead − 1.
      this.bits = ahead > 32 ? 0 : ahead === 32 ? 2 ** 31 : ((this.bits << ahead) | (1 << (ahead - 1))) >>> 0;
      this.newest = seq;
    } else {
      const behind = (this.newest - seq) & 0xffff;
      if (behind <= 32) {
        this.bits = (this.bits | (1 << (behind - 1))) >>> 0;
      }
    }
  }

  /** The datagram's `ack` and `ackBits`. */
  get(): { ack: number | null; ackBits: number } {
    return { ack: this.newest, ackBits: this.newest === null ? 0 : this.bits };
  }
}
