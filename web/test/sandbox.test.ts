// The golden vectors of the sandbox's input: the TypeScript encoder writes,
// from the same fields, the bytes the Rust encoder wrote.

import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { test } from "node:test";

import {
  decodeSandboxEvent,
  encodeSandboxInput,
  encodeSandboxRequest,
  MAX_CHAT_BYTES,
  SANDBOX_INPUT_BYTES,
  SandboxMessageError,
} from "../src/sandbox.js";

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

const MESSAGES = new URL("../../../sandbox/tests/vectors/messages.json", import.meta.url);

interface MessageVector {
  kind: string;
  fields: Record<string, unknown>;
  bytes: string;
}

function hex(s: string): Uint8Array {
  return Uint8Array.from(s.match(/../g) ?? [], (b) => parseInt(b, 16));
}

test("every sandbox event decodes to the fields the Rust encoder wrote, and a cut one is refused", () => {
  const vectors: MessageVector[] = JSON.parse(readFileSync(MESSAGES, "utf8")).events;
  assert.ok(vectors.length >= 7);
  for (const v of vectors) {
    const bytes = hex(v.bytes);
    const e = decodeSandboxEvent(bytes) as unknown as Record<string, unknown>;
    assert.equal(e.kind, v.kind);
    for (const [k, want] of Object.entries(v.fields)) {
      const got = e[k];
      if (typeof got === "bigint") {
        assert.equal(got, BigInt(want as number), `${v.kind}.${k}`);
      } else {
        assert.deepEqual(got, want, `${v.kind}.${k}`);
      }
    }
    assert.throws(() => decodeSandboxEvent(bytes.subarray(0, bytes.length - 1)), SandboxMessageError, v.kind);
    const padded = Uint8Array.from([...bytes, 0]);
    assert.throws(() => decodeSandboxEvent(padded), SandboxMessageError, `${v.kind}: padded`);
  }
  assert.throws(() => decodeSandboxEvent(Uint8Array.of(9)), SandboxMessageError);
});

test("every sandbox request encodes to the Rust encoder's bytes", () => {
  const vectors: MessageVector[] = JSON.parse(readFileSync(MESSAGES, "utf8")).requests;
  for (const v of vectors) {
    const request =
      v.kind === "respawn" ? ({ kind: "respawn" } as const) : ({ kind: "chat", text: v.fields.text as string } as const);
    assert.equal(toHex(encodeSandboxRequest(request)), v.bytes, v.kind);
  }
  assert.throws(() => encodeSandboxRequest({ kind: "chat", text: "x".repeat(MAX_CHAT_BYTES + 1) }), RangeError);
});
