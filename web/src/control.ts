// The control stream, as `protocol/src/control.rs` frames it: each message
// is a 4-byte little-endian length, then the message in postcard (serde's
// compact binary form: integers above a byte as LEB128 varints, reals as
// little-endian IEEE 754, enum variants as their index, strings and lists
// behind their length, options behind a 0 or 1 byte, fixed arrays and
// tuples element after element).
//
// Messages decode to the shape serde's JSON gives them (the golden vectors
// in `protocol/tests/vectors/control.json` are that JSON): an enum variant
// with data is `{ Variant: data }`, one without is `"Variant"`. 64-bit
// integers are `bigint`s.

/** A frame or message that is not of the protocol. */
export class ControlError extends Error {}

/** The longest frame payload, bytes (`MAX_CONTROL_FRAME`). */
export const MAX_CONTROL_FRAME = 64 * 1024;

/** The protocol version this client speaks (`PROTOCOL_VERSION`). */
export const PROTOCOL_VERSION = 8;

// ---- the messages ----

export type Vec3 = [number, number, number];
export type Quat = [number, number, number, number];

export type ShapeDesc =
  | { Sphere: { radius: number } }
  | { Cuboid: { half_extents: Vec3 } }
  | { Capsule: { half_height: number; radius: number } }
  | { Cylinder: { half_height: number; radius: number } }
  | { ConvexHull: { points: Vec3[] } }
  | { TriMesh: { vertices: Vec3[]; triangles: Vec3[] } }
  | { Compound: { parts: [Vec3, Quat, ShapeDesc][] } }
  | { Particle: { radius: number } }
  | "Ground"
  | { HeightField: { rows: number; cols: number; size: [number, number]; heights: number[] } }
  | {
      /** Points travel in snapshots as entities `id + 1 + i`. */
      PointSet: { points: number; radius: number; triangles: Vec3[]; lines: [number, number][] };
    };

export type EntityKind = "Static" | "Dynamic" | "Kinematic" | "Avatar" | "Water" | "SoftBody" | "Fluid";

export interface EntityDesc {
  id: number;
  kind: EntityKind;
  shape: ShapeDesc;
  /** RGBA, sRGB bytes. */
  color: [number, number, number, number];
  owner: bigint | null;
  name: string;
  position: Vec3;
  rotation: Quat;
}

export interface SnapshotParams {
  rotation_bits: number;
  velocity_resolution: number | null;
  velocity_bound: number;
  max_datagram: number;
}

export interface Welcome {
  client_id: bigint;
  tick: bigint;
  tick_hz: number;
  snapshot_hz: number;
  position_resolution: number;
  position_bound: number;
  snapshot: SnapshotParams;
  /** Bytes of every input's payload: the game's input size. */
  input_bytes: number;
  server_version: string;
  /** The game's name (empty when its rules give none): the page picks its controls by it. */
  game: string;
  /** The game's properties, per entity and per match, as snapshots carry them. */
  properties: PropertySchema;
}

/** A property's kind: what values it takes and its width on the wire. */
export type PropertyKind = "Bool" | { UInt: { bits: number } } | { Int: { bits: number } } | "F32";

/** One property a game declares. */
export interface PropertyDecl {
  name: string;
  kind: PropertyKind;
}

/** The properties a game declares, in the wire's order. */
export interface PropertySchema {
  entity: PropertyDecl[];
  match_state: PropertyDecl[];
}

export type TokenRefusal =
  | "Malformed"
  | "Forged"
  | { Expired: { expires_at: bigint; now: bigint } }
  | { WrongServer: { token: string; ours: string } }
  | "Reused";

export type Refusal =
  | { VersionMismatch: { server: number; client: number } }
  | { Token: TokenRefusal }
  | "ServerFull"
  | "ShuttingDown"
  | "Malformed"
  | "AlreadyConnected"
  | "Busy"
  | "SimulationStopped"
  | { Rejected: { reason: string } };

export type DisconnectReason =
  | "ServerShutdown"
  | { Kicked: { reason: string } }
  | "Timeout"
  | "ClientLeft"
  | { ProtocolError: { what: string } }
  | { SimulationStopped: { reason: string } }
  | { MatchOver: { reason: string } };

export type ServerControl =
  | { Welcome: Welcome }
  | { Refused: Refusal }
  | { Spawn: EntityDesc }
  | { Despawn: { id: number } }
  /** A reliable message of the game's: its bytes, read with the game's
   * decoder (the sandbox's: `decodeSandboxEvent`). */
  | { Message: number[] }
  | { Goodbye: DisconnectReason }
  | { InputTiming: InputReport };

/** How the client's inputs have been arriving against their ticks. */
export interface InputReport {
  on_time: bigint;
  late: bigint;
  refused: bigint;
  /** The least lead over the last second, ticks (negative: late). */
  min_lead: number | null;
}

export type ClientControl =
  | { Hello: { version: number; token: Uint8Array } }
  | "Goodbye"
  /** A reliable message of the game's: its bytes (at most {@link MAX_MESSAGE_BYTES}). */
  | { Message: Uint8Array };

/** The most bytes one game message may hold, either way. */
export const MAX_MESSAGE_BYTES = 1024;

/** The first byte of a message datagram (an unreliable game message). */
export const MESSAGE_DATAGRAM_TAG = 0x4d;

// ---- postcard ----

class Reader {
  private at = 0;
  private readonly view: DataView;

  constructor(private readonly bytes: Uint8Array) {
    this.view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  }

  private need(n: number): void {
    if (this.at + n > this.bytes.length) {
      throw new ControlError(`truncated: ${n} bytes wanted at ${this.at} of ${this.bytes.length}`);
    }
  }

  done(): void {
    if (this.at !== this.bytes.length) {
      throw new ControlError(`${this.bytes.length - this.at} bytes after the message`);
    }
  }

  u8(): number {
    this.need(1);
    return this.bytes[this.at++] ?? 0;
  }

  /** An unsigned LEB128 varint of at most `bits` bits. */
  varint(bits: number): bigint {
    let value = 0n;
    for (let shift = 0n; ; shift += 7n) {
      const byte = this.u8();
      value |= BigInt(byte & 0x7f) << shift;
      if ((byte & 0x80) === 0) {
        if (value >> BigInt(bits) !== 0n) {
          throw new ControlError(`a varint past ${bits} bits`);
        }
        return value;
      }
      if (shift > BigInt(bits)) {
        throw new ControlError(`a varint longer than ${bits} bits`);
      }
    }
  }

  u16(): number {
    return Number(this.varint(16));
  }

  u32(): number {
    return Number(this.varint(32));
  }

  u64(): bigint {
    return this.varint(64);
  }

  /** A zigzag-coded signed 32-bit integer. */
  i32(): number {
    const z = this.varint(32);
    return Number((z >> 1n) ^ -(z & 1n));
  }

  f32(): number {
    this.need(4);
    const v = this.view.getFloat32(this.at, true);
    this.at += 4;
    return v;
  }

  f64(): number {
    this.need(8);
    const v = this.view.getFloat64(this.at, true);
    this.at += 8;
    return v;
  }

  /** A list's length, which must fit in what is left (each element takes a byte at least). */
  length(): number {
    const n = this.u32();
    if (n > this.bytes.length - this.at) {
      throw new ControlError(`a list of ${n} in ${this.bytes.length - this.at} bytes`);
    }
    return n;
  }

  bytesField(): number[] {
    const n = this.length();
    const out = Array.from(this.bytes.subarray(this.at, this.at + n));
    this.at += n;
    return out;
  }

  string(): string {
    const n = this.length();
    const raw = this.bytes.subarray(this.at, this.at + n);
    this.at += n;
    try {
      return new TextDecoder("utf-8", { fatal: true }).decode(raw);
    } catch {
      throw new ControlError("a string that is not UTF-8");
    }
  }

  option<T>(read: () => T): T | null {
    const tag = this.u8();
    if (tag > 1) {
      throw new ControlError(`option tag ${tag}`);
    }
    return tag === 1 ? read() : null;
  }

  list<T>(read: () => T): T[] {
    const n = this.length();
    const out: T[] = [];
    for (let i = 0; i < n; i++) {
      out.push(read());
    }
    return out;
  }

  vec3f32(): Vec3 {
    return [this.f32(), this.f32(), this.f32()];
  }

  vec3f64(): Vec3 {
    return [this.f64(), this.f64(), this.f64()];
  }

  /** An enum's variant index, below `count`. */
  variant(what: string, count: number): number {
    const v = this.u32();
    if (v >= count) {
      throw new ControlError(`${what} variant ${v} of ${count}`);
    }
    return v;
  }
}

class Writer {
  private readonly out: number[] = [];

  u8(v: number): void {
    this.out.push(v & 0xff);
  }

  varint(v: bigint | number): void {
    let x = BigInt(v);
    do {
      let byte = Number(x & 0x7fn);
      x >>= 7n;
      if (x !== 0n) {
        byte |= 0x80;
      }
      this.out.push(byte);
    } while (x !== 0n);
  }

  bytes(b: Uint8Array): void {
    this.varint(b.length);
    for (const x of b) {
      this.out.push(x);
    }
  }

  /** The message behind its 4-byte little-endian length. */
  frame(): Uint8Array {
    const n = this.out.length;
    if (n > MAX_CONTROL_FRAME) {
      throw new ControlError(`a frame of ${n} bytes, the most is ${MAX_CONTROL_FRAME}`);
    }
    const framed = new Uint8Array(4 + n);
    new DataView(framed.buffer).setUint32(0, n, true);
    framed.set(this.out, 4);
    return framed;
  }
}

// ---- the server's messages ----

const SHAPE_DEPTH_LIMIT = 2;

function shape(r: Reader, depth: number): ShapeDesc {
  switch (r.variant("ShapeDesc", 11)) {
    case 0:
      return { Sphere: { radius: r.f32() } };
    case 1:
      return { Cuboid: { half_extents: r.vec3f32() } };
    case 2:
      return { Capsule: { half_height: r.f32(), radius: r.f32() } };
    case 3:
      return { Cylinder: { half_height: r.f32(), radius: r.f32() } };
    case 4:
      return { ConvexHull: { points: r.list(() => r.vec3f32()) } };
    case 5:
      return {
        TriMesh: {
          vertices: r.list(() => r.vec3f32()),
          triangles: r.list((): Vec3 => [r.u32(), r.u32(), r.u32()]),
        },
      };
    case 6: {
      if (depth >= SHAPE_DEPTH_LIMIT) {
        throw new ControlError("a compound inside a compound");
      }
      const parts = r.list((): [Vec3, Quat, ShapeDesc] => [
        r.vec3f32(),
        [r.f32(), r.f32(), r.f32(), r.f32()],
        shape(r, depth + 1),
      ]);
      return { Compound: { parts } };
    }
    case 7:
      return { Particle: { radius: r.f32() } };
    case 8:
      return "Ground";
    case 9: {
      const rows = r.u32();
      const cols = r.u32();
      const size: [number, number] = [r.f32(), r.f32()];
      return { HeightField: { rows, cols, size, heights: r.list(() => r.f32()) } };
    }
    default: {
      if (depth > 0) {
        throw new ControlError("a point set inside a compound");
      }
      const points = r.u32();
      const radius = r.f32();
      const triangles = r.list((): Vec3 => [r.u32(), r.u32(), r.u32()]);
      const lines = r.list((): [number, number] => [r.u32(), r.u32()]);
      return { PointSet: { points, radius, triangles, lines } };
    }
  }
}

const KINDS: EntityKind[] = ["Static", "Dynamic", "Kinematic", "Avatar", "Water", "SoftBody", "Fluid"];

function entity(r: Reader): EntityDesc {
  const id = r.u32();
  const kind = KINDS[r.variant("EntityKind", KINDS.length)] ?? "Static";
  const s = shape(r, 0);
  const color: [number, number, number, number] = [r.u8(), r.u8(), r.u8(), r.u8()];
  const owner = r.option(() => r.u64());
  const name = r.string();
  const position = r.vec3f64();
  const rotation: Quat = [r.f64(), r.f64(), r.f64(), r.f64()];
  return { id, kind, shape: s, color, owner, name, position, rotation };
}

function tokenRefusal(r: Reader): TokenRefusal {
  switch (r.variant("TokenRefusal", 5)) {
    case 0:
      return "Malformed";
    case 1:
      return "Forged";
    case 2:
      return { Expired: { expires_at: r.u64(), now: r.u64() } };
    case 3:
      return { WrongServer: { token: r.string(), ours: r.string() } };
    default:
      return "Reused";
  }
}

function refusal(r: Reader): Refusal {
  switch (r.variant("Refusal", 9)) {
    case 0:
      return { VersionMismatch: { server: r.u16(), client: r.u16() } };
    case 1:
      return { Token: tokenRefusal(r) };
    case 2:
      return "ServerFull";
    case 3:
      return "ShuttingDown";
    case 4:
      return "Malformed";
    case 5:
      return "AlreadyConnected";
    case 6:
      return "Busy";
    case 7:
      return "SimulationStopped";
    default:
      return { Rejected: { reason: r.string() } };
  }
}

function propertyKind(r: Reader): PropertyKind {
  switch (r.variant("PropertyKind", 4)) {
    case 0:
      return "Bool";
    case 1:
      return { UInt: { bits: r.u8() } };
    case 2:
      return { Int: { bits: r.u8() } };
    default:
      return "F32";
  }
}

function propertySchema(r: Reader): PropertySchema {
  const decls = (): PropertyDecl[] => r.list(() => ({ name: r.string(), kind: propertyKind(r) }));
  return { entity: decls(), match_state: decls() };
}

function disconnectReason(r: Reader): DisconnectReason {
  switch (r.variant("DisconnectReason", 7)) {
    case 0:
      return "ServerShutdown";
    case 1:
      return { Kicked: { reason: r.string() } };
    case 2:
      return "Timeout";
    case 3:
      return "ClientLeft";
    case 4:
      return { ProtocolError: { what: r.string() } };
    case 5:
      return { SimulationStopped: { reason: r.string() } };
    default:
      return { MatchOver: { reason: r.string() } };
  }
}

/** One server message from a frame's payload (without its length). */
export function decodeServerControl(payload: Uint8Array): ServerControl {
  if (payload.length > MAX_CONTROL_FRAME) {
    throw new ControlError(`a frame of ${payload.length} bytes, the most is ${MAX_CONTROL_FRAME}`);
  }
  const r = new Reader(payload);
  let msg: ServerControl;
  switch (r.variant("ServerControl", 7)) {
    case 0:
      msg = {
        Welcome: {
          client_id: r.u64(),
          tick: r.u64(),
          tick_hz: r.u32(),
          snapshot_hz: r.u32(),
          position_resolution: r.f64(),
          position_bound: r.f64(),
          snapshot: {
            rotation_bits: r.u8(),
            velocity_resolution: r.option(() => r.f64()),
            velocity_bound: r.f64(),
            max_datagram: r.u16(),
          },
          input_bytes: r.u16(),
          server_version: r.string(),
          game: r.string(),
          properties: propertySchema(r),
        },
      };
      break;
    case 1:
      msg = { Refused: refusal(r) };
      break;
    case 2:
      msg = { Spawn: entity(r) };
      break;
    case 3:
      msg = { Despawn: { id: r.u32() } };
      break;
    case 4: {
      const bytes = r.bytesField();
      if (bytes.length > MAX_MESSAGE_BYTES) {
        throw new ControlError(`a message of ${bytes.length} bytes, the most is ${MAX_MESSAGE_BYTES}`);
      }
      msg = { Message: bytes };
      break;
    }
    case 5:
      msg = { Goodbye: disconnectReason(r) };
      break;
    default:
      msg = {
        InputTiming: {
          on_time: r.u64(),
          late: r.u64(),
          refused: r.u64(),
          min_lead: r.option(() => r.i32()),
        },
      };
  }
  r.done();
  return msg;
}

/** A client message as a frame (length and payload), ready to write. */
export function encodeClientControl(msg: ClientControl): Uint8Array {
  const w = new Writer();
  if (msg === "Goodbye") {
    w.varint(1);
  } else if ("Message" in msg) {
    if (msg.Message.length > MAX_MESSAGE_BYTES) {
      throw new ControlError(`a message of ${msg.Message.length} bytes, the most is ${MAX_MESSAGE_BYTES}`);
    }
    w.varint(2);
    w.bytes(msg.Message);
  } else {
    w.varint(0);
    w.varint(msg.Hello.version);
    w.bytes(msg.Hello.token);
  }
  return w.frame();
}

/** Splits the bytes read from the control stream into frame payloads. */
export class FrameDecoder {
  private buffer = new Uint8Array(0);

  /** Takes bytes as they arrived. */
  push(bytes: Uint8Array): void {
    const joined = new Uint8Array(this.buffer.length + bytes.length);
    joined.set(this.buffer);
    joined.set(bytes, this.buffer.length);
    this.buffer = joined;
  }

  /** The next whole frame's payload, or `null` until it has all arrived. */
  next(): Uint8Array | null {
    if (this.buffer.length < 4) {
      return null;
    }
    const n = new DataView(this.buffer.buffer, this.buffer.byteOffset, 4).getUint32(0, true);
    if (n > MAX_CONTROL_FRAME) {
      throw new ControlError(`a frame of ${n} bytes, the most is ${MAX_CONTROL_FRAME}`);
    }
    if (this.buffer.length < 4 + n) {
      return null;
    }
    const payload = this.buffer.slice(4, 4 + n);
    this.buffer = this.buffer.slice(4 + n);
    return payload;
  }
}
