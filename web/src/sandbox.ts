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
