// The golden vectors of the input datagram: the TypeScript encoder writes,
// from the same fields, the bytes the Rust encoder wrote.

import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { test } from "node:test";

import { Acks, encodeInputDatagram, MAX_REDUNDANT_INPUTS } from "../src/input.js";

const FILE = new URL("../../../protocol/tests/vectors/inputs.json", import.meta.url);

interface Vector {
  name: string;
  bytes: string;
  ack: number | null;
  ack_bits: number;
  inputs: {
    sequence: number;
    tick: string;
    // The game's bytes, hex.
    payload: string;
    // null: NaN, which JSON cannot spell.
    view_behind: number | null;
  }[];
}

const vectors: Vector[] = JSON.parse(readFileSync(FILE, "utf8")).datagrams;

function fromHex(h: string): Uint8Array {
  return Uint8Array.from(h.match(/../g) ?? [], (x) => parseInt(x, 16));
}

function toHex(b: Uint8Array): string {
  return Array.from(b, (x) => x.toString(16).padStart(2, "0")).join("");
}

test("every input datagram encodes to the Rust encoder's bytes", () => {
  assert.ok(vectors.length >= 5);
  assert.ok(vectors.some((v) => v.inputs.length === MAX_REDUNDANT_INPUTS));
  for (const v of vectors) {
    const bytes = encodeInputDatagram({
      ack: v.ack,
      ackBits: v.ack_bits,
      inputs: v.inputs.map((i) => ({
        sequence: i.sequence,
        tick: BigInt(i.tick),
        payload: fromHex(i.payload),
        viewBehind: i.view_behind ?? NaN,
      })),
    });
    assert.equal(toHex(bytes), v.bytes, v.name);
  }
});

test("what the layout cannot carry is refused", () => {
  const input = { sequence: 1, tick: 1n, payload: new Uint8Array(5), viewBehind: 0 };
  assert.throws(() => encodeInputDatagram({ ack: null, ackBits: 1, inputs: [] }), RangeError);
  assert.throws(
    () => encodeInputDatagram({ ack: null, ackBits: 0, inputs: [{ ...input, payload: new Uint8Array(65) }] }),
    RangeError,
  );
  assert.throws(
    () => encodeInputDatagram({ ack: null, ackBits: 0, inputs: [input, { ...input, sequence: 0, payload: new Uint8Array(4) }] }),
    RangeError,
  );
  assert.throws(() => encodeInputDatagram({ ack: null, ackBits: 0, inputs: [input, input] }), RangeError);
  assert.throws(
    () => encodeInputDatagram({ ack: null, ackBits: 0, inputs: Array.from({ length: 9 }, (_, k) => ({ ...input, sequence: 9 - k })) }),
    RangeError,
  );
});

test("acknowledgements keep the newest sequence and the 32 before it", () => {
  const acks = new Acks();
  assert.deepEqual(acks.get(), { ack: null, ackBits: 0 });
  acks.received(65534);
  acks.received(1); // wrapped: three ahead
  assert.deepEqual(acks.get(), { ack: 1, ackBits: 0b100 });
  acks.received(0); // late
  assert.deepEqual(acks.get(), { ack: 1, ackBits: 0b101 });
  acks.received(40); // far ahead: the window is past them all
  assert.deepEqual(acks.get(), { ack: 40, ackBits: 0 });
  acks.received(72); // 32 ahead: only the old newest is in the window
  assert.deepEqual(acks.get(), { ack: 72, ackBits: 2 ** 31 });
});
