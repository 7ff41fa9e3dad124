// Point sets (soft bodies, fluids): which entity ids are a set's points,
// how a point is interpolated, and the meshes a set is drawn with.

import assert from "node:assert/strict";
import { test } from "node:test";

import type { EntityDesc } from "../src/control.js";
import { pointSetMesh, PointSetTrack } from "../src/points.js";

function set(triangles: [number, number, number][], lines: [number, number][], points = 4): EntityDesc {
  return {
    id: 10,
    kind: "SoftBody",
    shape: { PointSet: { points, radius: 0.02, triangles, lines } },
    color: [255, 255, 255, 255],
    owner: null,
    name: "cloth",
    position: [0, 0, 0],
    rotation: [0, 0, 0, 1],
  };
}

test("a set's points are the entities after it, interpolated over a snapshot interval", () => {
  const track = new PointSetTrack(set([[0, 1, 2]], []));
  assert.equal(track.indexOf(10), -1, "the set itself");
  assert.equal(track.indexOf(11), 0);
  assert.equal(track.indexOf(14), 3);
  assert.equal(track.indexOf(15), -1, "past its points");
  track.move(0, [0, 0, 0], 1000, 100);
  assert.deepEqual(track.pointAt(0, 1050, 100), [0, 0, 0], "a new point is placed, not slid in");
  track.move(0, [1, 0, 0], 1100, 100);
  const half = track.pointAt(0, 1150, 100);
  assert.ok(Math.abs(half[0] - 0.5) < 1e-6, `${half}`);
  track.hide(0);
  assert.equal(track.present[0], 0);
});

test("a cloth draws its known triangles with smooth normals, a rope tubes, a fluid balls", () => {
  const p = Float32Array.from([0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 1]);
  const all = Uint8Array.from([1, 1, 1, 1]);
  const cloth = set(
    [
      [0, 2, 1],
      [1, 2, 3],
    ],
    [],
  ).shape as { PointSet: Parameters<typeof pointSetMesh>[0] };
  let mesh = pointSetMesh(cloth.PointSet, p, all);
  assert.equal(mesh.indices.length, 6);
  assert.equal(mesh.vertices.length, 4 * 6, "corners shared");
  for (let k = 0; k < 4; k++) {
    assert.ok(Math.abs((mesh.vertices[6 * k + 4] ?? 0) - 1) < 1e-6, "up");
  }
  mesh = pointSetMesh(cloth.PointSet, p, Uint8Array.from([1, 1, 1, 0]));
  assert.equal(mesh.indices.length, 3, "a triangle on an unknown point is not drawn");

  const rope = (set([], [[0, 1], [1, 3]]).shape as typeof cloth).PointSet;
  mesh = pointSetMesh(rope, p, all);
  assert.equal(mesh.indices.length, 2 * 4 * 6, "two segments of four sides");
  assert.ok(mesh.vertices.every(Number.isFinite));

  const fluid = (set([], []).shape as typeof cloth).PointSet;
  mesh = pointSetMesh(fluid, p, Uint8Array.from([1, 0, 1, 0]));
  assert.equal(mesh.indices.length, 2 * 8 * 3, "an eight-faced ball per known point");
});
