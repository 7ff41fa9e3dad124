// Triangle meshes for the shapes a server describes, in the entity's own
// frame (m), as `viewer/src/mesh.rs` makes them for the native viewer:
// flat faces with a normal each, round surfaces and terrain smooth. A
// convex hull is drawn as its bounding box here.

import type { ShapeDesc, Vec3 } from "./control.js";

/** Interleaved position (3) and normal (3), and triangle indices. */
export interface Mesh {
  vertices: Float32Array;
  indices: Uint32Array;
}

class Builder {
  readonly v: number[] = [];
  readonly i: number[] = [];

  push(p: Vec3, n: Vec3): number {
    const len = Math.hypot(...n) || 1;
    this.v.push(p[0], p[1], p[2], n[0] / len, n[1] / len, n[2] / len);
    return this.v.length / 6 - 1;
  }

  /** A flat triangle of its own corners. */
  triangle(a: Vec3, b: Vec3, c: Vec3): void {
    const u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    const w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    const n: Vec3 = [
      (u[1] ?? 0) * (w[2] ?? 0) - (u[2] ?? 0) * (w[1] ?? 0),
      (u[2] ?? 0) * (w[0] ?? 0) - (u[0] ?? 0) * (w[2] ?? 0),
      (u[0] ?? 0) * (w[1] ?? 0) - (u[1] ?? 0) * (w[0] ?? 0),
    ];
    if (Math.hypot(...n) === 0) {
      return;
    }
    const k = this.push(a, n);
    this.push(b, n);
    this.push(c, n);
    this.i.push(k, k + 1, k + 2);
  }

  /** Appends `other` turned by the unit quaternion `q` and moved by `t`. */
  append(other: Builder, t: Vec3, q: [number, number, number, number]): void {
    const base = this.v.length / 6;
    for (let k = 0; k < other.v.length; k += 6) {
      const p = rotate(q, [other.v[k] ?? 0, other.v[k + 1] ?? 0, other.v[k + 2] ?? 0]);
      const n = rotate(q, [other.v[k + 3] ?? 0, other.v[k + 4] ?? 0, other.v[k + 5] ?? 0]);
      this.v.push(p[0] + t[0], p[1] + t[1], p[2] + t[2], n[0], n[1], n[2]);
    }
    for (const i of other.i) {
      this.i.push(base + i);
    }
  }

  mesh(): Mesh {
    return { vertices: Float32Array.from(this.v), indices: Uint32Array.from(this.i) };
  }
}

/** `v` turned by the unit quaternion `q` (x, y, z, w). */
export function rotate(q: [number, number, number, number], v: Vec3): Vec3 {
  const [x, y, z, w] = q;
  const tx = 2 * (y * v[2] - z * v[1]);
  const ty = 2 * (z * v[0] - x * v[2]);
  const tz = 2 * (x * v[1] - y * v[0]);
  return [
    v[0] + w * tx + (y * tz - z * ty),
    v[1] + w * ty + (z * tx - x * tz),
    v[2] + w * tz + (x * ty - y * tx),
  ];
}

function ball(b: Builder, radius: number, halfHeight: number, segments: number, rings: number): void {
  const r = Math.max(radius, 1e-4);
  const rows: [number, number][] = [];
  for (let k = 0; k <= rings; k++) {
    const polar = (Math.PI * k) / rings;
    rows.push([polar, 2 * k <= rings ? halfHeight : -halfHeight]);
    if (halfHeight > 0 && 2 * k === rings) {
      rows.push([polar, -halfHeight]);
    }
  }
  for (const [polar, lift] of rows) {
    for (let s = 0; s <= segments; s++) {
      const az = (2 * Math.PI * s) / segments;
      const n: Vec3 = [Math.sin(polar) * Math.cos(az), Math.cos(polar), Math.sin(polar) * Math.sin(az)];
      b.push([n[0] * r, n[1] * r + lift, n[2] * r], n);
    }
  }
  const row = segments + 1;
  for (let k = 0; k < rows.length - 1; k++) {
    for (let s = 0; s < segments; s++) {
      const a = k * row + s;
      b.i.push(a, a + 1, a + row, a + 1, a + row + 1, a + row);
    }
  }
}

function box(b: Builder, h: Vec3): void {
  for (let axis = 0; axis < 3; axis++) {
    for (const sign of [1, -1]) {
      const n: Vec3 = [0, 0, 0];
      n[axis] = sign;
      const u: Vec3 = [0, 0, 0];
      u[(axis + 1) % 3] = 1;
      const v: Vec3 = [n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]];
      const corner = (a: number, c: number): Vec3 =>
        [0, 1, 2].map((k) => ((n[k] ?? 0) + (u[k] ?? 0) * a + (v[k] ?? 0) * c) * (h[k] ?? 0)) as Vec3;
      const k = b.push(corner(-1, -1), n);
      b.push(corner(1, -1), n);
      b.push(corner(1, 1), n);
      b.push(corner(-1, 1), n);
      b.i.push(k, k + 1, k + 2, k, k + 2, k + 3);
    }
  }
}

function cylinder(b: Builder, h: number, r: number): void {
  const seg = 24;
  const around = (s: number): Vec3 => [Math.cos((2 * Math.PI * s) / seg), 0, Math.sin((2 * Math.PI * s) / seg)];
  const base = b.v.length / 6;
  for (let s = 0; s <= seg; s++) {
    const n = around(s);
    b.push([n[0] * r, h, n[2] * r], n);
    b.push([n[0] * r, -h, n[2] * r], n);
  }
  for (let s = 0; s < seg; s++) {
    const top = base + 2 * s;
    b.i.push(top, top + 2, top + 1, top + 2, top + 3, top + 1);
  }
  for (const sign of [1, -1]) {
    const n: Vec3 = [0, sign, 0];
    const c = b.push([0, sign * h, 0], n);
    for (let s = 0; s < seg; s++) {
      const p = around(s);
      const q = around(s + 1);
      const a = b.push([p[0] * r, sign * h, p[2] * r], n);
      const d = b.push([q[0] * r, sign * h, q[2] * r], n);
      b.i.push(...(sign > 0 ? [c, d, a] : [c, a, d]));
    }
  }
}

function build(b: Builder, shape: ShapeDesc, depth: number): void {
  if (shape === "Ground") {
    const s = 500;
    const n: Vec3 = [0, 1, 0];
    const k = b.push([-s, 0, -s], n);
    b.push([-s, 0, s], n);
    b.push([s, 0, s], n);
    b.push([s, 0, -s], n);
    b.i.push(k, k + 1, k + 2, k, k + 2, k + 3);
  } else if ("Sphere" in shape) {
    ball(b, shape.Sphere.radius, 0, 20, 12);
  } else if ("Particle" in shape) {
    ball(b, shape.Particle.radius, 0, 8, 6);
  } else if ("Capsule" in shape) {
    ball(b, shape.Capsule.radius, shape.Capsule.half_height, 20, 12);
  } else if ("Cuboid" in shape) {
    box(b, shape.Cuboid.half_extents);
  } else if ("Cylinder" in shape) {
    cylinder(b, shape.Cylinder.half_height, shape.Cylinder.radius);
  } else if ("ConvexHull" in shape) {
    const pts = shape.ConvexHull.points;
    if (pts.length === 0) {
      return;
    }
    const lo = [0, 1, 2].map((k) => Math.min(...pts.map((p) => p[k] ?? 0)));
    const hi = [0, 1, 2].map((k) => Math.max(...pts.map((p) => p[k] ?? 0)));
    const part = new Builder();
    box(part, [0, 1, 2].map((k) => Math.max(((hi[k] ?? 0) - (lo[k] ?? 0)) / 2, 1e-4)) as Vec3);
    b.append(part, [0, 1, 2].map((k) => ((hi[k] ?? 0) + (lo[k] ?? 0)) / 2) as Vec3, [0, 0, 0, 1]);
  } else if ("TriMesh" in shape) {
    const v = shape.TriMesh.vertices;
    for (const [a, c, d] of shape.TriMesh.triangles) {
      const pa = v[a];
      const pc = v[c];
      const pd = v[d];
      if (pa && pc && pd) {
        b.triangle(pa, pc, pd);
      }
    }
  } else if ("HeightField" in shape) {
    const { rows, cols, size, heights } = shape.HeightField;
    if (rows < 2 || cols < 2 || heights.length !== rows * cols) {
      return;
    }
    const at = (r: number, c: number): Vec3 => [
      (c * size[0]) / (cols - 1) - size[0] / 2,
      heights[r * cols + c] ?? 0,
      (r * size[1]) / (rows - 1) - size[1] / 2,
    ];
    const base = b.v.length / 6;
    for (let r = 0; r < rows; r++) {
      for (let c = 0; c < cols; c++) {
        const x0 = at(r, Math.max(c - 1, 0));
        const x1 = at(r, Math.min(c + 1, cols - 1));
        const z0 = at(Math.max(r - 1, 0), c);
        const z1 = at(Math.min(r + 1, rows - 1), c);
        const ax: Vec3 = [x1[0] - x0[0], x1[1] - x0[1], x1[2] - x0[2]];
        const az: Vec3 = [z1[0] - z0[0], z1[1] - z0[1], z1[2] - z0[2]];
        // along_z × along_x: up.
        b.push(at(r, c), [az[1] * ax[2] - az[2] * ax[1], az[2] * ax[0] - az[0] * ax[2], az[0] * ax[1] - az[1] * ax[0]]);
      }
    }
    for (let r = 0; r < rows - 1; r++) {
      for (let c = 0; c < cols - 1; c++) {
        const a = base + r * cols + c;
        b.i.push(a, a + cols, a + 1, a + 1, a + cols, a + cols + 1);
      }
    }
  } else if ("Compound" in shape && depth === 0) {
    for (const [offset, rotation, part] of shape.Compound.parts) {
      const sub = new Builder();
      build(sub, part, depth + 1);
      const n = Math.hypot(...rotation) || 1;
      b.append(sub, offset, rotation.map((x) => x / n) as [number, number, number, number]);
    }
  }
}

/** The mesh that draws `shape`. */
export function meshOf(shape: ShapeDesc): Mesh {
  const b = new Builder();
  build(b, shape, 0);
  return b.mesh();
}
