// Reading the bit-packed fields of a datagram, least significant bit
// first, as `protocol/src/bits.rs` writes them.

/** The datagram ended before a field, or a field is out of its range. */
export class SnapshotError extends Error {}

export class BitReader {
  private at = 0;

  constructor(private readonly bytes: Uint8Array) {}

  /** Bits not yet read. */
  bitsLeft(): number {
    return this.bytes.length * 8 - this.at;
  }

  /** An unsigned field of 1 to 32 bits. */
  read(bits: number): number {
    if (bits < 1 || bits > 32) {
      throw new RangeError(`bit width ${bits} outside 1..=32`);
    }
    if (bits > this.bitsLeft()) {
      throw new SnapshotError(`truncated: ${bits} bits wanted, ${this.bitsLeft()} left`);
    }
    let value = 0;
    let got = 0;
    while (got < bits) {
      const byte = this.bytes[this.at >> 3] ?? 0;
      const offset = this.at & 7;
      const take = Math.min(8 - offset, bits - got);
      const part = (byte >> offset) & ((1 << take) - 1);
      // Multiplying keeps a 32-bit field positive.
      value += part * 2 ** got;
      got += take;
      this.at += take;
    }
    return value;
  }

  /** An unsigned field of up to 64 bits (a tick). */
  readBig(bits: number): bigint {
    let value = 0n;
    let got = 0;
    while (got < bits) {
      const take = Math.min(32, bits - got);
      value |= BigInt(this.read(take)) << BigInt(got);
      got += take;
    }
    return value;
  }

  readBool(): boolean {
    return this.read(1) === 1;
  }

  /** A two's-complement field of 1 to 32 bits. */
  readSigned(bits: number): number {
    const raw = this.read(bits);
    const sign = 2 ** (bits - 1);
    return raw >= sign ? raw - 2 * sign : raw;
  }
}

/** Writing bit-packed fields, least significant bit first, as
 * `protocol/src/bits.rs` writes them; the last byte is padded with zeros. */
export class BitWriter {
  private readonly bytes: number[] = [];
  /** Bits of the last, unfinished byte. */
  private used = 0;

  /** An unsigned field of 1 to 32 bits. */
  write(value: number, bits: number): void {
    if (bits < 1 || bits > 32) {
      throw new RangeError(`bit width ${bits} outside 1..=32`);
    }
    if (!Number.isInteger(value) || value < 0 || value >= 2 ** bits) {
      throw new RangeError(`${value} does not fit ${bits} bits`);
    }
    let left = bits;
    let v = value;
    while (left > 0) {
      if (this.used === 0) {
        this.bytes.push(0);
      }
      const take = Math.min(8 - this.used, left);
      const part = v % 2 ** take;
      const i = this.bytes.length - 1;
      this.bytes[i] = (this.bytes[i] ?? 0) | (part << this.used);
      v = Math.floor(v / 2 ** take);
      left -= take;
      this.used = (this.used + take) % 8;
    }
  }

  /** An unsigned field of up to 64 bits. */
  writeBig(value: bigint, bits: number): void {
    let v = value;
    let left = bits;
    while (left > 0) {
      const take = Math.min(32, left);
      this.write(Number(v & ((1n << BigInt(take)) - 1n)), take);
      v >>= BigInt(take);
      left -= take;
    }
  }

  writeBool(value: boolean): void {
    this.write(value ? 1 : 0, 1);
  }

  /** The bytes written. */
  finish(): Uint8Array {
    return Uint8Array.from(this.bytes);
  }
}
