// Soft bodies and fluids: one entity described as a point set, whose
// points travel in snapshots as the entities `id + 1 + i` (no spawn of
// their own). Each point is interpolated like a body, between its last
// two states over one snapshot interval; the set is drawn as one mesh in
// world coordinates made every frame: its triangles with smooth normals
// (cloth, a solid's surface), a thin square tube per line (a rope), or a
// small ball per point (a fluid). As `client-sdk/src/point_sets.rs` and
// `viewer/src/point_sets.rs` do for native games.

import type { EntityDesc, Vec3 } from "./control.js";
import type { Mesh } from "./mesh.js";

type PointSetShape = Extract<EntityDesc["shape"], { PointSet: unknown }>["PointSet"];

/** The point set of `desc`, if its shape is one. */
export function pointSetOf(desc: EntityDesc): PointSetShape | null {
  const shape = desc.shape;
  return typeof shape === "object" && "PointSet" in shape ? shape.PointSet : null;
}

/** One set's points: their last two positions, arrival times (ms), and
 * which of them a snapshot has placed (and not taken out of view). */
export class PointSetTrack {
  readonly shape: PointSetShape;
  readonly before: Float32Array;
  readonly after: Float32Array;
  readonly at: Float64Array;
  readonly present: Uint8Array;

  constructor(readonly desc: EntityDesc) {
    const shape = pointSetOf(desc);
    if (!shape) {
      throw new Error(`entity ${desc.id} is not a point set`);
    }
    this.shape = shape;
    const n = shape.points;
    this.before = new Float32Array(3 * n);
    this.after = new Float32Array(3 * n);
    this.at = new Float64Array(n);
    this.present = new Uint8Array(n);
  }

  /** The point entity `id` stands for, or -1. */
  indexOf(id: number): number {
    const i = id - this.desc.id - 1;
    return i >= 0 && i < this.shape.points ? i : -1;
  }

  /** Point `i` is at `p` as of `now`, having been where it was drawn. */
  move(i: number, p: Vec3, now: number, interval: number): void {
    if (this.present[i]) {
      const q = this.pointAt(i, now, interval);
      this.before.set(q, 3 * i);
    } else {
      this.before.set(p, 3 * i);
    }
    this.after.set(p, 3 * i);
    this.at[i] = now;
    this.present[i] = 1;
  }

  /** Point `i` left the view. */
  hide(i: number): void {
    this.present[i] = 0;
  }

  /** Where point `i` is drawn at `now` (ms). */
  pointAt(i: number, now: number, interval: number): Vec3 {
    const u = Math.min(Math.max((now - (this.at[i] ?? 0)) / interval, 0), 1);
    const k = 3 * i;
    const lerp = (j: number): number => {
      const a = this.before[k + j] ?? 0;
      return a + ((this.after[k + j] ?? 0) - a) * u;
    };
    return [lerp(0), lerp(1), lerp(2)];
  }

  /** The set's mesh at `now`, world coordinates. */
  mesh(now: number, interval: number): Mesh {
    const n = this.shape.points;
    const p = new Float32Array(3 * n);
    for (let i = 0; i < n; i++) {
      if (this.present[i]) {
        p.set(this.pointAt(i, now, interval), 3 * i);
      }
    }
    return pointSetMesh(this.shape, p, this.present);
  }
}

/** The mesh of a point set with its points at `p` (x, y, z each), only
 * the `present` ones drawn. */
export function pointSetMesh(shape: PointSetShape, p: Float32Array, present: Uint8Array): Mesh {
  const v: number[] = [];
  const idx: number[] = [];
  const at = (i: number): Vec3 => [p[3 * i] ?? 0, p[3 * i + 1] ?? 0, p[3 * i + 2] ?? 0];
  const known = (i: number): boolean => present[i] === 1;
  const triangles = shape.triangles.filter((t) => t.every(known));
  if (triangles.length > 0) {
    // Smooth normals: area-weighted face normals summed at each point.
    const normals = new Float32Array(p.length);
    for (const [a, b, c] of triangles) {
      const n = cross(sub(at(b), at(a)), sub(at(c), at(a)));
      for (const i of [a, b, c]) {
        normals[3 * i] = (normals[3 * i] ?? 0) + n[0];
        normals[3 * i + 1] = (normals[3 * i + 1] ?? 0) + n[1];
        normals[3 * i + 2] = (normals[3 * i + 2] ?? 0) + n[2];
      }
    }
    const slot = new Map<number, number>();
    for (const t of triangles) {
      for (const i of t) {
        let s = slot.get(i);
        if (s === undefined) {
          s = v.length / 6;
          slot.set(i, s);
          const n: Vec3 = [normals[3 * i] ?? 0, normals[3 * i + 1] ?? 0, normals[3 * i + 2] ?? 0];
          const len = Math.hypot(...n) || 1;
          v.push(...at(i), n[0] / len, n[1] / len, n[2] / len);
        }
        idx.push(s);
      }
    }
  }
  const r = Math.max(shape.radius, 0.005);
  for (const [a, b] of shape.lines) {
    if (known(a) && known(b)) {
      tube(v, idx, at(a), at(b), r);
    }
  }
  if (triangles.length === 0 && shape.lines.length === 0) {
    for (let i = 0; i < shape.points; i++) {
      if (known(i)) {
        octahedron(v, idx, at(i), r);
      }
    }
  }
  return { vertices: Float32Array.from(v), indices: Uint32Array.from(idx) };
}

function sub(a: Vec3, b: Vec3): Vec3 {
  return [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
}

function cross(a: Vec3, b: Vec3): Vec3 {
  return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
}

/** Four flat sides of half-width `r` from `a` to `b`. */
function tube(v: number[], idx: number[], a: Vec3, b: Vec3, r: number): void {
  const axis = sub(b, a);
  const len = Math.hypot(...axis);
  if (!(len > 1e-6)) {
    return;
  }
  const d: Vec3 = [axis[0] / len, axis[1] / len, axis[2] / len];
  const helper: Vec3 = Math.abs(d[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
  const u0 = cross(d, helper);
  const ul = Math.hypot(...u0);
  const u: Vec3 = [u0[0] / ul, u0[1] / ul, u0[2] / ul];
  const w = cross(d, u);
  const neg = (x: Vec3): Vec3 => [-x[0], -x[1], -x[2]];
  for (const [n, across] of [
    [u, w],
    [w, neg(u)],
    [neg(u), neg(w)],
    [neg(w), u],
  ] as [Vec3, Vec3][]) {
    const base = v.length / 6;
    for (const [end, s] of [
      [a, -1],
      [a, 1],
      [b, 1],
      [b, -1],
    ] as [Vec3, number][]) {
      v.push(
        end[0] + (n[0] + s * across[0]) * r,
        end[1] + (n[1] + s * across[1]) * r,
        end[2] + (n[2] + s * across[2]) * r,
        ...n,
      );
    }
    idx.push(base, base + 1, base + 2, base, base + 2, base + 3);
  }
}

/** A small ball of radius `r` at `c`: eight flat faces, cheap for
 * thousands of fluid particles. */
function octahedron(v: number[], idx: number[], c: Vec3, r: number): void {
  const k = 1 / Math.sqrt(3);
  for (const sx of [-1, 1]) {
    for (const sy of [-1, 1]) {
      for (const sz of [-1, 1]) {
        const corners: Vec3[] = [
          [sx * r, 0, 0],
          [0, sy * r, 0],
          [0, 0, sz * r],
        ];
        const base = v.length / 6;
        for (const q of corners) {
          v.push(c[0] + q[0], c[1] + q[1], c[2] + q[2], sx * k, sy * k, sz * k);
        }
        idx.push(base, base + 1, base + 2);
      }
    }
  }
}
