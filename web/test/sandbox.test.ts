// The golden vectors of the sandbox's input: the TypeScript encoder writes,
// from the same fields, the bytes the Rust encoder wrote.

import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { test } from "node:test";

import { encodeSandboxInput, SANDBOX_INPUT_BYTES } from "../src/sandbox.js";

const FILE = new URL("../../../sandbox/tests/vectors/inputs.json", import.meta.url);

// null: NaN; "inf" and "-inf": the infinities, which JSON cannot spell.
type Num = number | null | "inf" | "-inf";

interface Vector {
  movement: [Num, Num];
  yaw: Num;
  buttons: number;
  bytes: string;
}

function num(x: Num): number {
  return x === null ? NaN : x === "inf" ? Infinity : x === "-inf" ? -Infinity : x;
}

function toHex(b: Uint8Array): string {
  return Array.from(b, (x) => x.toString(16).padStart(2, "0")).join("");
}

test("every sandbox input encodes to the Rust encoder's bytes", () => {
  const vectors: Vector[] = JSON.parse(readFileSync(FILE, "utf8")).inputs;
  assert.ok(vectors.length >= 10);
  for (const v of vectors) {
    const bytes = encodeSandboxInput({
      movement: [num(v.movement[0]), num(v.movement[1])],
      yaw: num(v.yaw),
      buttons: v.buttons,
    });
    assert.equal(bytes.length, SANDBOX_INPUT_BYTES);
    assert.equal(toHex(bytes), v.bytes, JSON.stringify(v));
  }
});
