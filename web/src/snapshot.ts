// The snapshot datagram (server → client), decoded as
// `protocol/src/snapshot/decoder.rs` decodes it. The layout is documented
// in `protocol/src/snapshot/mod.rs`; `protocol/tests/vectors/snapshots.json`
// holds datagrams the Rust encoder wrote and what the Rust decoder read
// from them, and `test/vectors.test.ts` decodes them here, so the two
// decoders cannot drift apart.

import { BitReader, SnapshotError } from "./bits.js";
import type { PropertyKind, PropertySchema } from "./control.js";

export { SnapshotError };

/** First byte of every snapshot datagram ('S'). */
export const SNAPSHOT_TAG = 0x53;
/** Views kept, by sequence number. */
export const RING = 64;
/** The most entities one view may hold. */
export const MAX_ENTITIES = 16_384;
/** The largest time scale either way. */
export const MAX_TIME_SCALE = 64;

// Size classes of each code (bit widths), as `code.rs` has them.
const ID_CLASSES = [2, 5, 9, 32];
const COUNT_CLASSES = [3, 6, 14];
const TICK_CLASSES = [4, 8, 16];
const POSITION_CLASSES = [0, 4, 7, 10];
const ROTATION_CLASSES = [3, 6, 9];
const VELOCITY_CLASSES = [0, 4, 7, 10];
/** The fewest bits an updated entity takes (bounds the count read). */
const MIN_ENTITY_BITS = 6;

/** A grid of coordinates: a step and a bound, m (or m/s). */
export interface Grid {
  resolution: number;
  bound: number;
}

/** How snapshots are quantized and sized: both ends use the same. */
export interface SnapshotConfig {
  grid: Grid;
  rotationBits: number;
  velocities: boolean;
  velocityGrid: Grid;
  maxDatagram: number;
}

/** Bits of a grid index. */
export function gridBits(g: Grid): number {
  // The bit length of the last index.
  let last = Math.ceil((2 * g.bound) / g.resolution);
  let bits = 0;
  while (last > 0) {
    bits++;
    last = Math.floor(last / 2);
  }
  return Math.max(1, bits);
}

/** The largest index of a grid (that of its bound). */
function gridMax(g: Grid): number {
  return Math.round((g.bound + g.bound) / g.resolution);
}

/** The coordinate of a grid index. */
export function coordinate(g: Grid, i: number): number {
  return i * g.resolution - g.bound;
}

/** A rotation as smallest three: the dropped component, the other levels. */
export interface QuantizedRotation {
  largest: number;
  small: [number, number, number];
}

/** One entity exactly as snapshots carry it. */
export interface QuantizedEntity {
  position: [number, number, number];
  rotation: QuantizedRotation;
  velocity: [number, number, number] | null;
  atRest: boolean;
}

/** One entity as the snapshot shows it, in world units. */
export interface ViewEntity {
  id: number;
  quantized: QuantizedEntity;
  /** Position of its origin, m. */
  position: [number, number, number];
  /** Unit quaternion, x y z w. */
  rotation: [number, number, number, number];
  /** Linear velocity, m/s of simulation time, when sent. */
  velocity: [number, number, number] | null;
}

export interface DecodedSnapshot {
  sequence: number;
  baseline: number | null;
  tick: bigint;
  timeScale: number;
  paused: boolean;
  removed: number[];
  updated: ViewEntity[];
  /** The property rows this snapshot changed (raw values, whole rows), by id. */
  properties: [number, bigint[]][];
  /** The match's properties (raw), when this snapshot changed them. */
  matchState: bigint[] | null;
}

/** Bits one value of `kind` takes. */
export function propertyBits(kind: PropertyKind): number {
  if (kind === "Bool") return 1;
  if (kind === "F32") return 32;
  return "UInt" in kind ? kind.UInt.bits : kind.Int.bits;
}

/** A raw property value as a number (a flag 0 or 1, a signed integer
 * sign-extended, a float read from its bits). */
export function propertyValue(kind: PropertyKind, raw: bigint): number {
  if (kind === "F32") {
    const v = new DataView(new ArrayBuffer(4));
    v.setUint32(0, Number(raw), true);
    return v.getFloat32(0, true);
  }
  if (kind !== "Bool" && "Int" in kind) {
    return Number(BigInt.asIntN(kind.Int.bits, raw));
  }
  return Number(raw);
}

/** A view: its tick, its entities in ascending id order, and the game's
 * properties (rows by entity; the match's). */
interface View {
  tick: bigint;
  ids: number[];
  states: QuantizedEntity[];
  props: Map<number, bigint[]>;
  matchState: bigint[] | null;
}

const SMALL_BOUND = Math.SQRT1_2;

/** The unit quaternion (x y z w) the levels stand for. */
export function rotationFromLevels(
  largest: number,
  small: [number, number, number],
  bits: number,
): [number, number, number, number] {
  const levels = 2 ** bits - 1;
  const q = [0, 0, 0, 0];
  let sum = 0;
  let k = 0;
  for (let i = 0; i < 4; i++) {
    if (i === (largest & 3)) continue;
    const unit = Math.min((small[k] ?? 0) / levels, 1);
    k++;
    q[i] = unit * 2 * SMALL_BOUND - SMALL_BOUND;
    sum += q[i]! * q[i]!;
  }
  q[largest & 3] = Math.sqrt(Math.max(1 - sum, 0));
  let len2 = 0;
  for (const c of q) len2 += c * c;
  const len = Math.sqrt(len2);
  return [q[0]! / len, q[1]! / len, q[2]! / len, q[3]! / len];
}

/** Whether sequence `a` is newer than `b`, modulo 2^16. */
export function sequenceNewer(a: number, b: number): boolean {
  return a !== b && ((a - b) & 0xffff) < 0x8000;
}

function readVaruint(r: BitReader, classes: number[]): number {
  let start = 0;
  for (let i = 0; i < classes.length; i++) {
    const bits = classes[i]!;
    const last = i + 1 === classes.length;
    if (last || !r.readBool()) {
      return start + (bits === 0 ? 0 : r.read(bits));
    }
    start += 2 ** bits;
  }
  throw new Error("classes are never empty");
}

function readClass(r: BitReader, n: number): number {
  let c = 0;
  while (c < n && r.readBool()) c++;
  return c;
}

function inRange(v: number, max: number): number {
  if (v < 0 || v > max) throw new SnapshotError("index outside its grid");
  return v;
}

function readAbsolute(r: BitReader, bits: number, max: number): [number, number, number] {
  const v = (): number => inRange(r.read(bits), max);
  return [v(), v(), v()];
}

function readTriple(
  r: BitReader,
  base: [number, number, number],
  classes: number[],
  absBits: number,
  max: number,
): [number, number, number] {
  const axis = (k: number): number => {
    const c = readClass(r, classes.length);
    const bits = classes[c];
    if (bits === undefined) return inRange(r.read(absBits), max);
    return inRange(base[k]! + (bits === 0 ? 0 : r.readSigned(bits)), max);
  };
  return [axis(0), axis(1), axis(2)];
}

function readBody(r: BitReader, base: QuantizedEntity | undefined, c: SnapshotConfig): QuantizedEntity {
  const atRest = r.readBool();
  const pbits = gridBits(c.grid);
  const pmax = gridMax(c.grid);
  const position = base
    ? readTriple(r, base.position, POSITION_CLASSES, pbits, pmax)
    : readAbsolute(r, pbits, pmax);
  const rbits = c.rotationBits;
  const rmax = 2 ** rbits - 1;
  const n = ROTATION_CLASSES.length;
  let rotation: QuantizedRotation;
  if (base && !r.readBool()) {
    rotation = base.rotation;
  } else {
    const cls = base ? readClass(r, n) : n;
    if (base && cls < n) {
      const bits = ROTATION_CLASSES[cls]!;
      const s = base.rotation.small;
      const d = (k: number): number => inRange(s[k]! + r.readSigned(bits), rmax);
      rotation = { largest: base.rotation.largest, small: [d(0), d(1), d(2)] };
    } else {
      const largest = r.read(2);
      rotation = { largest, small: readAbsolute(r, rbits, rmax) };
    }
  }
  let velocity: [number, number, number] | null = null;
  if (c.velocities && !atRest) {
    const vbits = gridBits(c.velocityGrid);
    const vmax = gridMax(c.velocityGrid);
    velocity = base?.velocity
      ? readTriple(r, base.velocity, VELOCITY_CLASSES, vbits, vmax)
      : readAbsolute(r, vbits, vmax);
  }
  return { position, rotation, velocity, atRest };
}

function readIds(r: BitReader, bound: number): number[] {
  const count = readVaruint(r, COUNT_CLASSES);
  if (count > bound) throw new SnapshotError("count above its bound");
  const ids: number[] = [];
  let prev: number | null = null;
  for (let i = 0; i < count; i++) {
    const gap = readVaruint(r, ID_CLASSES);
    const id: number = prev === null ? gap : prev + 1 + gap;
    if (id > 0xffff_ffff) throw new SnapshotError("entity id overflows");
    ids.push(id);
    prev = id;
  }
  return ids;
}

/** Reads a raw value of `bits` bits (up to 64). */
function readRaw(r: BitReader, bits: number): bigint {
  let v = 0n;
  let got = 0;
  while (got < bits) {
    const take = Math.min(32, bits - got);
    v |= BigInt(r.read(take)) << BigInt(got);
    got += take;
  }
  return v;
}

/** One property change onto `before` (missing: zeros): the new row, as
 * `protocol/src/snapshot/property_section.rs` reads it. */
function readChange(r: BitReader, kinds: PropertyKind[], before: bigint[] | undefined | null): bigint[] {
  const mask = readRaw(r, kinds.length);
  if (mask === 0n) throw new SnapshotError("a property change that changes nothing");
  const row = kinds.map((_, i) => before?.[i] ?? 0n);
  kinds.forEach((kind, i) => {
    if (((mask >> BigInt(i)) & 1n) === 0n) return;
    const raw = readRaw(r, propertyBits(kind));
    if (kind === "F32" && !Number.isFinite(propertyValue(kind, raw))) {
      throw new SnapshotError("a property value out of its kind");
    }
    if (raw === row[i]) throw new SnapshotError("a property change to the same value");
    row[i] = raw;
  });
  return row;
}

/** Finds `id` in a view's ascending ids, from `at` on (a cursor). */
function findFrom(view: View, at: { i: number }, id: number): number | undefined {
  while (at.i < view.ids.length && view.ids[at.i]! < id) at.i++;
  return view.ids[at.i] === id ? at.i : undefined;
}

/**
 * Decodes snapshots in the order they arrive, holding the views of the
 * last {@link RING} by sequence number (each is the baseline of a later
 * one). Bytes are untrusted: a bad datagram throws a
 * {@link SnapshotError} and changes nothing.
 */
export class SnapshotDecoder {
  private readonly views = new Map<number, View>();
  private newest: number | null = null;

  /** A decoder for snapshots coded under `config`, carrying the game's
   * properties of `schema` (the welcome's; none by default). */
  constructor(
    readonly config: SnapshotConfig,
    readonly schema: PropertySchema = { entity: [], match_state: [] },
  ) {}

  decode(bytes: Uint8Array): DecodedSnapshot {
    const c = this.config;
    if (bytes.length > c.maxDatagram) throw new SnapshotError("datagram too long");
    const r = new BitReader(bytes);
    if (r.read(8) !== SNAPSHOT_TAG) throw new SnapshotError("not a snapshot");
    const sequence = r.read(16);
    if (this.views.has(sequence)) throw new SnapshotError(`duplicate snapshot ${sequence}`);
    if (this.newest !== null && sequenceNewer(this.newest, sequence) && ((this.newest - sequence) & 0xffff) >= RING) {
      throw new SnapshotError(`stale snapshot ${sequence}`);
    }
    let baseline: number | null = null;
    if (r.readBool()) {
      baseline = r.read(16);
      if (!sequenceNewer(sequence, baseline) || ((sequence - baseline) & 0xffff) > RING) {
        throw new SnapshotError("baseline not within the ring before the snapshot");
      }
    }
    const empty: View = { tick: 0n, ids: [], states: [], props: new Map(), matchState: null };
    const base = baseline === null ? empty : this.views.get(baseline);
    if (!base) throw new SnapshotError(`baseline ${baseline} is not held`);
    let tick: bigint;
    if (r.readBool()) {
      if (baseline === null) throw new SnapshotError("relative tick without a baseline");
      tick = base.tick + BigInt(readVaruint(r, TICK_CLASSES));
      if (tick >= 1n << 64n) throw new SnapshotError("tick overflows");
    } else {
      tick = r.readBig(64);
    }
    let timeScale = 1;
    if (!r.readBool()) {
      const raw = new DataView(new ArrayBuffer(4));
      raw.setUint32(0, r.read(32), true);
      timeScale = raw.getFloat32(0, true);
    }
    if (!(Number.isFinite(timeScale) && Math.abs(timeScale) <= MAX_TIME_SCALE)) {
      throw new SnapshotError("time scale not finite or beyond ±MAX_TIME_SCALE");
    }
    const paused = r.readBool();

    const removed = readIds(r, Math.min(base.ids.length, MAX_ENTITIES, Math.floor(r.bitsLeft() / 3)));
    const cursor = { i: 0 };
    if (removed.some((id) => findFrom(base, cursor, id) === undefined)) {
      throw new SnapshotError("removal of an entity not in view");
    }
    const count = readVaruint(r, COUNT_CLASSES);
    if (count > Math.min(MAX_ENTITIES, Math.floor(r.bitsLeft() / MIN_ENTITY_BITS))) {
      throw new SnapshotError("count above its bound");
    }
    const updatedIds: number[] = [];
    const updatedStates: QuantizedEntity[] = [];
    const removedSet = new Set(removed);
    const at = { i: 0 };
    let prev: number | null = null;
    let fresh = 0;
    for (let k = 0; k < count; k++) {
      const gap = readVaruint(r, ID_CLASSES);
      const id: number = prev === null ? gap : prev + 1 + gap;
      if (id > 0xffff_ffff) throw new SnapshotError("entity id overflows");
      prev = id;
      if (removedSet.has(id)) throw new SnapshotError("entity both removed and updated");
      const held = findFrom(base, at, id);
      if (held === undefined) fresh++;
      updatedIds.push(id);
      updatedStates.push(readBody(r, held === undefined ? undefined : base.states[held], c));
    }
    if (base.ids.length - removed.length + fresh > MAX_ENTITIES) {
      throw new SnapshotError("view above MAX_ENTITIES");
    }

    // The game's properties: the match's change, then the entities'.
    const entityKinds = this.schema.entity.map((d) => d.kind);
    const matchKinds = this.schema.match_state.map((d) => d.kind);
    let matchState: bigint[] | null = null;
    if (matchKinds.length > 0 && r.readBool()) {
      matchState = readChange(r, matchKinds, base.matchState);
    }
    const properties: [number, bigint[]][] = [];
    if (entityKinds.length > 0) {
      const bound = Math.min(MAX_ENTITIES, Math.floor(r.bitsLeft() / (2 + entityKinds.length)));
      const n = readVaruint(r, COUNT_CLASSES);
      if (n > bound) throw new SnapshotError("count above its bound");
      const updatedSet = new Set(updatedIds);
      const inBase = new Set(base.ids);
      let last: number | null = null;
      for (let k = 0; k < n; k++) {
        const gap = readVaruint(r, ID_CLASSES);
        const id: number = last === null ? gap : last + 1 + gap;
        if (id > 0xffff_ffff) throw new SnapshotError("entity id overflows");
        if (!(updatedSet.has(id) || (inBase.has(id) && !removedSet.has(id)))) {
          throw new SnapshotError("properties of an entity not in view");
        }
        properties.push([id, readChange(r, entityKinds, base.props.get(id))]);
        last = id;
      }
    }
    if (r.bitsLeft() >= 8) throw new SnapshotError("trailing bytes");

    // The new view: the baseline less the removals, with the updates in.
    const props = new Map(base.props);
    for (const id of removed) props.delete(id);
    for (const [id, row] of properties) props.set(id, row);
    const view: View = { tick, ids: [], states: [], props, matchState: matchState ?? base.matchState };
    let u = 0;
    for (let i = 0; i < base.ids.length; i++) {
      const id = base.ids[i]!;
      while (u < updatedIds.length && updatedIds[u]! < id) {
        view.ids.push(updatedIds[u]!);
        view.states.push(updatedStates[u]!);
        u++;
      }
      if (updatedIds[u] === id) {
        view.ids.push(id);
        view.states.push(updatedStates[u]!);
        u++;
      } else if (!removedSet.has(id)) {
        view.ids.push(id);
        view.states.push(base.states[i]!);
      }
    }
    for (; u < updatedIds.length; u++) {
      view.ids.push(updatedIds[u]!);
      view.states.push(updatedStates[u]!);
    }
    this.views.set(sequence, view);
    if (this.newest === null || sequenceNewer(sequence, this.newest)) this.newest = sequence;
    for (const s of this.views.keys()) {
      if (((this.newest - s) & 0xffff) >= RING) this.views.delete(s);
    }

    const updated = updatedIds.map((id, k) => this.dequantize(id, updatedStates[k]!));
    return { sequence, baseline, tick, timeScale, paused, removed, updated, properties, matchState };
  }

  /** The properties of entity `id` in the view of `sequence` (raw, schema
   * order; undefined: none set, or not held). */
  properties(sequence: number, id: number): bigint[] | undefined {
    return this.views.get(sequence)?.props.get(id);
  }

  /** The match's properties in the view of `sequence` (raw; null: none set). */
  matchState(sequence: number): bigint[] | null {
    return this.views.get(sequence)?.matchState ?? null;
  }

  /** The entities of the view of `sequence`, in world units. */
  entities(sequence: number): ViewEntity[] | undefined {
    const v = this.views.get(sequence);
    return v?.ids.map((id, k) => this.dequantize(id, v.states[k]!));
  }

  private dequantize(id: number, q: QuantizedEntity): ViewEntity {
    const c = this.config;
    const at = (g: Grid, i: [number, number, number]): [number, number, number] => [
      coordinate(g, i[0]),
      coordinate(g, i[1]),
      coordinate(g, i[2]),
    ];
    return {
      id,
      quantized: q,
      position: at(c.grid, q.position),
      rotation: rotationFromLevels(q.rotation.largest, q.rotation.small, c.rotationBits),
      velocity: q.velocity ? at(c.velocityGrid, q.velocity) : null,
    };
  }
}
