// The golden vectors of football's input and messages: the TypeScript
// codecs write and read, from the same fields, the bytes the Rust
// encoders wrote.

import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { test } from "node:test";

import {
  decodeFootballTell,
  encodeFootballAsk,
  encodeFootballPlay,
  FOOTBALL_INPUT_BYTES,
  FootballMessageError,
  footballHeadline,
} from "../src/football.js";

const FILE = new URL("../../../games/football/tests/vectors/football.json", import.meta.url);
const vectors = JSON.parse(readFileSync(FILE, "utf8"));

type Num = number | null | "inf" | "-inf";

function num(x: Num): number {
  return x === null ? NaN : x === "inf" ? Infinity : x === "-inf" ? -Infinity : x;
}

function toHex(b: Uint8Array): string {
  return Array.from(b, (x) => x.toString(16).padStart(2, "0")).join("");
}

function hex(s: string): Uint8Array {
  return Uint8Array.from(s.match(/../g) ?? [], (b) => parseInt(b, 16));
}

interface MessageVector {
  kind: string;
  fields: Record<string, unknown>;
  bytes: string;
}

test("every football play encodes to the Rust encoder's bytes", () => {
  assert.equal(vectors.input_bytes, FOOTBALL_INPUT_BYTES);
  assert.ok(vectors.plays.length >= 12);
  for (const v of vectors.plays) {
    const bytes = encodeFootballPlay({
      stick: [num(v.stick[0]), num(v.stick[1])],
      yaw: num(v.yaw),
      pitch: num(v.pitch),
      buttons: v.buttons,
    });
    assert.equal(toHex(bytes), v.bytes, JSON.stringify(v));
  }
});

test("every message the rules tell decodes to the fields the Rust encoder wrote, and a cut one is refused", () => {
  const tells: MessageVector[] = vectors.tells;
  assert.ok(tells.length >= 7);
  for (const v of tells) {
    const bytes = hex(v.bytes);
    const t = decodeFootballTell(bytes) as unknown as Record<string, unknown>;
    assert.equal(t.kind, v.kind);
    for (const [k, want] of Object.entries(v.fields)) {
      const got = t[k];
      if (typeof got === "bigint") {
        assert.equal(got, BigInt(want as number), `${v.kind}.${k}`);
      } else {
        assert.deepEqual(got, want, `${v.kind}.${k}`);
      }
    }
    assert.throws(() => decodeFootballTell(bytes.subarray(0, bytes.length - 1)), FootballMessageError, v.kind);
    assert.throws(() => decodeFootballTell(Uint8Array.from([...bytes, 0])), FootballMessageError, `${v.kind}: padded`);
  }
  assert.throws(() => decodeFootballTell(Uint8Array.of(9)), FootballMessageError);
  assert.throws(() => decodeFootballTell(Uint8Array.of(2, 3)), FootballMessageError, "no team 3");
});

test("every ask encodes to the Rust encoder's bytes", () => {
  for (const v of vectors.asks as MessageVector[]) {
    const ask =
      v.kind === "switch_team" ? ({ kind: "switch_team" } as const) : ({ kind: "say", text: v.fields.text as string } as const);
    assert.equal(toHex(encodeFootballAsk(ask)), v.bytes, v.kind);
  }
  // A long line is cut where the Rust encoder cuts it.
  assert.equal(encodeFootballAsk({ kind: "say", text: "é".repeat(80) }).length, 2 + 100);
});

test("the headline reads the match's properties", () => {
  assert.equal(footballHeadline([1, 0], 151, 2, 0), "red 1 – 0 blue · 2:31 · playing");
  assert.equal(footballHeadline([2, 3], 0, 3, 2), "red 2 – 3 blue · 0:00 · blue wins");
});
