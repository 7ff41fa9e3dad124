// The golden vectors of the control stream, read and written here: every
// frame the Rust encoder wrote must decode to the message it holds, and
// every client message must encode to the Rust encoder's bytes.

import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { test } from "node:test";

import {
  ControlError,
  decodeServerControl,
  encodeClientControl,
  FrameDecoder,
  PROTOCOL_VERSION,
  type ClientControl,
} from "../src/control.js";

const FILE = new URL("../../../protocol/tests/vectors/control.json", import.meta.url);

interface Vector {
  name: string;
  frame: string;
  message: unknown;
}

const vectors: { protocol_version: number; server: Vector[]; client: Vector[] } = JSON.parse(
  readFileSync(FILE, "utf8"),
);

function hex(s: string): Uint8Array {
  return Uint8Array.from(s.match(/../g) ?? [], (b) => parseInt(b, 16));
}

function toHex(b: Uint8Array): string {
  return Array.from(b, (x) => x.toString(16).padStart(2, "0")).join("");
}

/** `actual` as decoded against `expected` as serde's JSON wrote it, where a
 * 64-bit integer is a `bigint` on one side and a number or decimal text on
 * the other. */
function same(actual: unknown, expected: unknown, at: string): void {
  if (typeof actual === "bigint") {
    assert.ok(
      typeof expected === "number" || typeof expected === "string",
      `${at}: a 64-bit integer where ${JSON.stringify(expected)} was written`,
    );
    assert.equal(actual, BigInt(expected), at);
  } else if (Array.isArray(actual)) {
    assert.ok(Array.isArray(expected), `${at}: a list`);
    assert.equal(actual.length, expected.length, `${at}: length`);
    actual.forEach((v, i) => same(v, expected[i], `${at}[${i}]`));
  } else if (actual !== null && typeof actual === "object") {
    assert.ok(expected !== null && typeof expected === "object", `${at}: an object`);
    const a = Object.keys(actual).sort();
    const e = Object.keys(expected).sort();
    assert.deepEqual(a, e, `${at}: fields`);
    for (const k of a) {
      same((actual as Record<string, unknown>)[k], (expected as Record<string, unknown>)[k], `${at}.${k}`);
    }
  } else {
    assert.equal(actual, expected, at);
  }
}

test("the client speaks the vectors' protocol version", () => {
  assert.equal(PROTOCOL_VERSION, vectors.protocol_version);
});

test("every server frame decodes to the message the Rust encoder wrote", () => {
  assert.ok(vectors.server.length > 30);
  for (const v of vectors.server) {
    const frame = hex(v.frame);
    // Arriving in two pieces, split inside the length.
    const frames = new FrameDecoder();
    frames.push(frame.subarray(0, 2));
    assert.equal(frames.next(), null, `${v.name}: half a length`);
    frames.push(frame.subarray(2));
    const payload = frames.next();
    assert.ok(payload, `${v.name}: a whole frame`);
    assert.equal(frames.next(), null, `${v.name}: one frame`);
    same(decodeServerControl(payload), v.message, v.name);
  }
});

test("every client message encodes to the Rust encoder's bytes", () => {
  for (const v of vectors.client) {
    const m = v.message as "Goodbye" | { Hello: { version: number; token: number[] } } | { Message: number[] };
    const msg: ClientControl =
      m === "Goodbye"
        ? "Goodbye"
        : "Message" in m
          ? { Message: Uint8Array.from(m.Message) }
          : { Hello: { version: m.Hello.version, token: Uint8Array.from(m.Hello.token) } };
    assert.equal(toHex(encodeClientControl(msg)), v.frame, v.name);
  }
});

test("truncated, padded and out-of-range frames are refused", () => {
  for (const v of vectors.server) {
    const payload = hex(v.frame).subarray(4);
    if (payload.length > 1) {
      assert.throws(() => decodeServerControl(payload.subarray(0, payload.length - 1)), ControlError, v.name);
    }
    const padded = new Uint8Array(payload.length + 1);
    padded.set(payload);
    assert.throws(() => decodeServerControl(padded), ControlError, `${v.name}: padded`);
  }
  // An unknown message, a list longer than the frame, a frame too large.
  assert.throws(() => decodeServerControl(Uint8Array.of(6)), ControlError);
  assert.throws(() => decodeServerControl(Uint8Array.of(2, 1, 0, 4, 0xff, 0xff, 0x03)), ControlError);
  const frames = new FrameDecoder();
  frames.push(Uint8Array.of(0, 0, 2, 0));
  assert.throws(() => frames.next(), ControlError);
});
