//! The field codes snapshots are made of: variable-length unsigned
//! integers in size classes, and triples of grid indices as small signed
//! deltas from a baseline. Each writer is generic over [`BitSink`] so that
//! the encoder can count an entity's exact size with the very code that
//! writes it.
//!
//! These are bit-level codes of their own, not the byte codec's LEB128
//! varint and zigzag ([`inertia_codec`]): a value's size class is told in
//! truncated unary and its bits follow at exactly the class's width, so a
//! small value costs a few bits rather than a byte; and a delta is two's
//! complement in its class's fixed width, where a zigzag would save no bit.

use crate::bits::{BitReader, BitWriter};

use super::view::{QuantizedEntity, QuantizedRotation};
use super::{SnapshotConfig, SnapshotError};

/// Somewhere bits go: a real writer, or a counter.
pub(crate) trait BitSink {
    /// Writes the low `bits` bits of `value` (`bits` may be 0: nothing).
    fn put(&mut self, value: u64, bits: u32);
}

impl BitSink for BitWriter {
    fn put(&mut self, value: u64, bits: u32) {
        if bits > 0 {
            self.write(value, bits);
        }
    }
}

/// Counts bits instead of writing them.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct BitCount(pub(crate) usize);

impl BitSink for BitCount {
    fn put(&mut self, _value: u64, bits: u32) {
        self.0 += bits as usize;
    }
}

/// Gaps between ascending entity ids: runs of neighbours (0–3) in 3
/// bits, a row of the world's grid away in 7, anything in at most 35.
pub(crate) const ID_CLASSES: [u32; 4] = [2, 5, 9, 32];
/// Counts of entities and removals (the last class reaches past
/// [`super::MAX_ENTITIES`]).
pub(crate) const COUNT_CLASSES: [u32; 3] = [3, 6, 14];
/// Tick distance from the baseline's tick.
pub(crate) const TICK_CLASSES: [u32; 3] = [4, 8, 16];

/// Position deltas, per axis (grid steps, signed bits; 0: unchanged):
/// most bodies that move stay on the ground (their height unchanged), and
/// a push moves one a few hundred millimetres between baselines.
pub(crate) const POSITION_CLASSES: [u32; 4] = [0, 4, 7, 10];
/// Rotation deltas of the three small components (steps, signed bits).
pub(crate) const ROTATION_CLASSES: [u32; 3] = [3, 6, 9];
/// Velocity deltas, per axis (grid steps, signed bits; 0: unchanged).
pub(crate) const VELOCITY_CLASSES: [u32; 4] = [0, 4, 7, 10];

/// Writes `value` in the first class of `classes` (bit widths) it fits:
/// the class index in truncated unary (`i` ones then a zero, no zero after
/// the last), then `value` less the class's start.
///
/// # Panics
/// If `value` fits no class: a bug in the caller.
pub(crate) fn write_varuint(s: &mut impl BitSink, value: u64, classes: &[u32]) {
    let mut start = 0u64;
    for (i, &bits) in classes.iter().enumerate() {
        let size = 1u64.checked_shl(bits).unwrap_or(0);
        let last = i + 1 == classes.len();
        if last || value - start < size {
            assert!(
                bits == 64 || value - start < size,
                "{value} fits no class of {classes:?}"
            );
            s.put(u64::MAX >> (64 - i.max(1)), i as u32);
            if !last {
                s.put(0, 1);
            }
            s.put(value - start, bits);
            return;
        }
        start += size;
    }
}

/// Reads a value written by [`write_varuint`].
pub(crate) fn read_varuint(r: &mut BitReader<'_>, classes: &[u32]) -> Result<u64, SnapshotError> {
    let mut start = 0u64;
    for (i, &bits) in classes.iter().enumerate() {
        let last = i + 1 == classes.len();
        if last || !r.read_bool()? {
            let v = if bits == 0 { 0 } else { r.read(bits)? };
            return start.checked_add(v).ok_or(SnapshotError::Malformed(
                "variable-length integer overflows",
            ));
        }
        start += 1u64 << bits;
    }
    unreachable!("classes are never empty")
}

/// Bits of `value` under [`write_varuint`].
pub(crate) fn varuint_bits(value: u64, classes: &[u32]) -> usize {
    let mut c = BitCount::default();
    write_varuint(&mut c, value, classes);
    c.0
}

/// The size class (index into `classes`) whose signed width holds every
/// delta `cur - base`, or `classes.len()` for none.
fn delta_class(cur: [u32; 3], base: [u32; 3], classes: &[u32]) -> usize {
    let worst = (0..3)
        .map(|k| i64::from(cur[k]) - i64::from(base[k]))
        .map(|d| if d < 0 { -d - 1 } else { d })
        .max()
        .unwrap_or(0);
    classes
        .iter()
        .position(|&bits| worst < 1i64 << (bits - 1))
        .unwrap_or(classes.len())
}

/// Writes a size class in truncated unary: `class` ones, then a zero
/// unless `class` is the last of `0 ..= n`.
fn write_class(s: &mut impl BitSink, class: usize, n: usize) {
    s.put((1u64 << class) - 1, class as u32);
    if class < n {
        s.put(0, 1);
    }
}

/// Reads a class written by [`write_class`].
fn read_class(r: &mut BitReader<'_>, n: usize) -> Result<usize, SnapshotError> {
    let mut class = 0;
    while class < n && r.read_bool()? {
        class += 1;
    }
    Ok(class)
}

/// Writes three indices against `base`, each axis on its own: a
/// truncated-unary class (one more code than `classes` means absolute),
/// then the signed delta in the class's width (0: none, the axis is
/// unchanged), or the absolute index in `abs_bits`.
pub(crate) fn write_triple(
    s: &mut impl BitSink,
    cur: [u32; 3],
    base: [u32; 3],
    classes: &[u32],
    abs_bits: u32,
) {
    for k in 0..3 {
        let d = i64::from(cur[k]) - i64::from(base[k]);
        let class = classes
            .iter()
            .position(|&bits| fits(d, bits))
            .unwrap_or(classes.len());
        write_class(s, class, classes.len());
        match classes.get(class) {
            Some(&bits) => s.put(d as u64, bits),
            None => s.put(u64::from(cur[k]), abs_bits),
        }
    }
}

/// Whether `d` fits a signed field of `bits` (0 bits: only 0).
fn fits(d: i64, bits: u32) -> bool {
    match bits {
        0 => d == 0,
        _ => -(1i64 << (bits - 1)) <= d && d < 1i64 << (bits - 1),
    }
}

fn write_deltas(s: &mut impl BitSink, cur: [u32; 3], base: [u32; 3], bits: u32) {
    for k in 0..3 {
        let d = i64::from(cur[k]) - i64::from(base[k]);
        s.put(d as u64, bits);
    }
}

/// Reads three indices written by [`write_triple`], each at most `max`.
pub(crate) fn read_triple(
    r: &mut BitReader<'_>,
    base: [u32; 3],
    classes: &[u32],
    abs_bits: u32,
    max: u32,
) -> Result<[u32; 3], SnapshotError> {
    let mut out = [0u32; 3];
    for k in 0..3 {
        let class = read_class(r, classes.len())?;
        let v = match classes.get(class) {
            Some(0) => i64::from(base[k]),
            Some(&bits) => i64::from(base[k]) + r.read_signed(bits)?,
            None => r.read(abs_bits)? as i64,
        };
        if !(0..=i64::from(max)).contains(&v) {
            return Err(SnapshotError::Malformed("index outside its grid"));
        }
        out[k] = v as u32;
    }
    Ok(out)
}

fn read_deltas(
    r: &mut BitReader<'_>,
    base: [u32; 3],
    bits: u32,
    max: u32,
) -> Result<[u32; 3], SnapshotError> {
    let mut out = [0u32; 3];
    for k in 0..3 {
        let v = i64::from(base[k]) + r.read_signed(bits)?;
        if !(0..=i64::from(max)).contains(&v) {
            return Err(SnapshotError::Malformed("index outside its grid"));
        }
        out[k] = v as u32;
    }
    Ok(out)
}

/// Writes three absolute indices of `bits` each.
pub(crate) fn write_absolute(s: &mut impl BitSink, v: [u32; 3], bits: u32) {
    for x in v {
        s.put(u64::from(x), bits);
    }
}

/// Reads three absolute indices, each at most `max`.
pub(crate) fn read_absolute(
    r: &mut BitReader<'_>,
    bits: u32,
    max: u32,
) -> Result<[u32; 3], SnapshotError> {
    let mut out = [0u32; 3];
    for x in &mut out {
        *x = r.read_count(bits, u64::from(max), "grid index")? as u32;
    }
    Ok(out)
}

/// Writes one entity's state (everything but its id) against its
/// baseline state, if the baseline view holds it.
pub(crate) fn write_body(
    s: &mut impl BitSink,
    q: &QuantizedEntity,
    base: Option<&QuantizedEntity>,
    config: &SnapshotConfig,
) {
    s.put(u64::from(q.at_rest), 1);
    let pbits = config.grid.bits();
    match base {
        Some(b) => write_triple(s, q.position, b.position, &POSITION_CLASSES, pbits),
        None => write_absolute(s, q.position, pbits),
    }
    let rbits = config.rotation_bits;
    let small = q.rotation.small.map(u32::from);
    let n = ROTATION_CLASSES.len();
    let class = match base {
        Some(b) if b.rotation == q.rotation => {
            s.put(0, 1);
            None
        }
        Some(b) => {
            s.put(1, 1);
            let class = if b.rotation.largest == q.rotation.largest {
                delta_class(small, b.rotation.small.map(u32::from), &ROTATION_CLASSES)
            } else {
                n
            };
            write_class(s, class, n);
            Some(class)
        }
        None => Some(n),
    };
    match class {
        Some(c) if c < n => {
            let b = base.map_or([0; 3], |b| b.rotation.small.map(u32::from));
            write_deltas(s, small, b, ROTATION_CLASSES[c]);
        }
        Some(_) => {
            s.put(u64::from(q.rotation.largest), 2);
            write_absolute(s, small, rbits);
        }
        None => {}
    }
    if let Some(v) = q.velocity {
        let vbits = config.velocity_grid.bits();
        match base.and_then(|b| b.velocity) {
            Some(bv) => write_triple(s, v, bv, &VELOCITY_CLASSES, vbits),
            None => write_absolute(s, v, vbits),
        }
    }
}

/// Reads one entity's state written by [`write_body`].
pub(crate) fn read_body(
    r: &mut BitReader<'_>,
    base: Option<&QuantizedEntity>,
    config: &SnapshotConfig,
) -> Result<QuantizedEntity, SnapshotError> {
    let max_index = |g: &crate::quantize::PositionGrid| g.index(g.bound) as u32;
    let at_rest = r.read_bool()?;
    let (pbits, pmax) = (config.grid.bits(), max_index(&config.grid));
    let position = match base {
        Some(b) => read_triple(r, b.position, &POSITION_CLASSES, pbits, pmax)?,
        None => read_absolute(r, pbits, pmax)?,
    };
    let rbits = config.rotation_bits;
    let rmax = (1u32 << rbits) - 1;
    let n = ROTATION_CLASSES.len();
    let rotation = match base {
        Some(b) if !r.read_bool()? => b.rotation,
        _ => {
            let class = if base.is_some() { read_class(r, n)? } else { n };
            match base {
                Some(b) if class < n => {
                    let small = b.rotation.small.map(u32::from);
                    let small = read_deltas(r, small, ROTATION_CLASSES[class], rmax)?;
                    QuantizedRotation {
                        largest: b.rotation.largest,
                        small: small.map(|c| c as u16),
                    }
                }
                _ => {
                    let largest = r.read(2)? as u8;
                    let small = read_absolute(r, rbits, rmax)?;
                    QuantizedRotation {
                        largest,
                        small: small.map(|c| c as u16),
                    }
                }
            }
        }
    };
    let velocity = if config.velocities && !at_rest {
        let (vbits, vmax) = (
            config.velocity_grid.bits(),
            max_index(&config.velocity_grid),
        );
        Some(match base.and_then(|b| b.velocity) {
            Some(bv) => read_triple(r, bv, &VELOCITY_CLASSES, vbits, vmax)?,
            None => read_absolute(r, vbits, vmax)?,
        })
    } else {
        None
    };
    Ok(QuantizedEntity {
        position,
        rotation,
        velocity,
        at_rest,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn varuints_round_trip_at_every_class_edge() {
        let values = [0u64, 3, 4, 35, 36, 547, 548, u64::from(u32::MAX)];
        let mut w = BitWriter::new();
        for &v in &values {
            write_varuint(&mut w, v, &ID_CLASSES);
        }
        let sizes: Vec<usize> = values
            .iter()
            .map(|&v| varuint_bits(v, &ID_CLASSES))
            .collect();
        assert_eq!(sizes, [3, 3, 7, 7, 12, 12, 35, 35]);
        assert_eq!(w.bit_len(), sizes.iter().sum::<usize>());
        let bytes = w.finish();
        let mut r = BitReader::new(&bytes);
        for &v in &values {
            assert_eq!(read_varuint(&mut r, &ID_CLASSES).unwrap(), v);
        }
    }

    #[test]
    fn triples_take_the_smallest_class_of_each_axis() {
        let base = [2000, 2000, 2000];
        let cases = [
            ([2000, 2000, 2000], 3),
            ([2003, 2000, 1992], 6 + 1 + 6),
            ([2008, 2000, 2000], 10 + 1 + 1),
            ([2000, 2000, 2000 - 512], 1 + 1 + 14),
            ([2000, 2000 + 512, 2000], 1 + 4 + 20 + 1),
        ];
        let mut w = BitWriter::new();
        for (cur, bits) in cases {
            let mut c = BitCount::default();
            write_triple(&mut c, cur, base, &POSITION_CLASSES, 20);
            assert_eq!(c.0, bits, "{cur:?}");
            write_triple(&mut w, cur, base, &POSITION_CLASSES, 20);
        }
        let bytes = w.finish();
        let mut r = BitReader::new(&bytes);
        for (cur, _) in cases {
            let got = read_triple(&mut r, base, &POSITION_CLASSES, 20, (1 << 20) - 1).unwrap();
            assert_eq!(got, cur);
        }
    }

    #[test]
    fn deltas_off_the_grid_are_refused() {
        let mut w = BitWriter::new();
        write_triple(&mut w, [0, 0, 0], [3, 3, 3], &POSITION_CLASSES, 20);
        let bytes = w.finish();
        let err = read_triple(
            &mut BitReader::new(&bytes),
            [1, 1, 1],
            &POSITION_CLASSES,
            20,
            100,
        );
        assert!(matches!(err, Err(SnapshotError::Malformed(_))));
    }
}
