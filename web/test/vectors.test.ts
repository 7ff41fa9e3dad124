// The golden vectors of the snapshot format, decoded here: every datagram
// the Rust encoder wrote must read as the Rust decoder read it.

import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { test } from "node:test";

import {
  gridBits,
  SnapshotDecoder,
  SnapshotError,
  type SnapshotConfig,
} from "../src/snapshot.js";
import type { PropertySchema } from "../src/control.js";

const FILE = new URL("../../../protocol/tests/vectors/snapshots.json", import.meta.url);

interface JsonGrid {
  resolution: number;
  bound: number;
  bits: number;
}

interface JsonStream {
  name: string;
  config: {
    grid: JsonGrid;
    rotation_bits: number;
    velocities: boolean;
    velocity_grid: JsonGrid;
    max_datagram: number;
  };
  snapshots: {
    bytes: string;
    sequence: number;
    baseline: number | null;
    tick: string;
    time_scale: number;
    paused: boolean;
    removed: number[];
    updated: {
      id: number;
      quantized: {
        position: number[];
        rotation: { largest: number; small: number[] };
        velocity: number[] | null;
        at_rest: boolean;
      };
      position: number[];
      rotation: number[];
      velocity: number[] | null;
    }[];
    properties: [number, string[]][];
    match_state: string[] | null;
  }[];
  properties: PropertySchema;
}

const streams: JsonStream[] = JSON.parse(readFileSync(FILE, "utf8")).streams;

function hex(s: string): Uint8Array {
  return Uint8Array.from(s.match(/../g) ?? [], (b) => parseInt(b, 16));
}

function config(s: JsonStream): SnapshotConfig {
  const c = s.config;
  return {
    grid: { resolution: c.grid.resolution, bound: c.grid.bound },
    rotationBits: c.rotation_bits,
    velocities: c.velocities,
    velocityGrid: { resolution: c.velocity_grid.resolution, bound: c.velocity_grid.bound },
    maxDatagram: c.max_datagram,
  };
}

test("the vectors hold streams", () => {
  assert.ok(streams.length >= 2);
});

for (const stream of streams) {
  test(`stream ${stream.name} decodes as the Rust decoder read it`, () => {
    const c = config(stream);
    assert.equal(gridBits(c.grid), stream.config.grid.bits);
    assert.equal(gridBits(c.velocityGrid), stream.config.velocity_grid.bits);
    const decoder = new SnapshotDecoder(c, stream.properties);
    for (const want of stream.snapshots) {
      const got = decoder.decode(hex(want.bytes));
      const at = `${stream.name} #${want.sequence}`;
      assert.deepEqual(
        got.properties.map(([id, row]) => [id, row.map(String)]),
        want.properties,
        `${at}: properties`,
      );
      assert.deepEqual(got.matchState?.map(String) ?? null, want.match_state, `${at}: match state`);
      assert.equal(got.sequence, want.sequence, at);
      assert.equal(got.baseline, want.baseline, at);
      assert.equal(got.tick, BigInt(want.tick), at);
      assert.equal(got.timeScale, Math.fround(want.time_scale), at);
      assert.equal(got.paused, want.paused, at);
      assert.deepEqual(got.removed, want.removed, at);
      assert.equal(got.updated.length, want.updated.length, at);
      got.updated.forEach((e, k) => {
        const w = want.updated[k]!;
        const q = w.quantized;
        assert.equal(e.id, w.id, at);
        assert.deepEqual(
          e.quantized,
          {
            position: q.position,
            rotation: q.rotation,
            velocity: q.velocity,
            atRest: q.at_rest,
          },
          `${at} entity ${w.id}`,
        );
        assert.deepEqual(e.position, w.position, `${at} entity ${w.id}`);
        assert.deepEqual(e.rotation, w.rotation, `${at} entity ${w.id}`);
        assert.deepEqual(e.velocity, w.velocity, `${at} entity ${w.id}`);
      });
    }
  });
}

test("bad bytes throw a SnapshotError and change nothing", () => {
  const stream = streams[0]!;
  const decoder = new SnapshotDecoder(config(stream));
  const first = hex(stream.snapshots[0]!.bytes);
  // Every cut of the first datagram, and a wrong tag.
  for (let cut = 0; cut < first.length; cut++) {
    assert.throws(() => decoder.decode(first.slice(0, cut)), SnapshotError);
  }
  const wrong = first.slice();
  wrong[0] = 0x49;
  assert.throws(() => decoder.decode(wrong), SnapshotError);
  // A later snapshot against a baseline never received.
  assert.throws(() => decoder.decode(hex(stream.snapshots[1]!.bytes)), SnapshotError);
  // And the whole stream still decodes afterwards.
  for (const s of stream.snapshots) {
    assert.equal(decoder.decode(hex(s.bytes)).sequence, s.sequence);
  }
});
