//! The recording store end to end on real files: every record kind round
//! trips, segments roll over at keyframes, a torn tail is cut on open (its
//! bytes kept aside) and appending continues, damage is never cut — in the
//! newest segment it is left alone and appending goes on in a new segment,
//! in an older one it is reported where it is — retention drops the oldest
//! segments, and random bytes never panic.

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use inertia_server::record::{
    Corruption, LegacyInput, OpenReport, Record, RecordError, RecordOptions, RecordReader,
    RecordWriter, Salvaged, SegmentDamage, MAX_RECORD_BYTES,
};
use proptest::prelude::*;

/// A fresh directory under the system temp dir, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let path =
            std::env::temp_dir().join(format!("inertia-record-{name}-{}-{n}", std::process::id()));
        let _ = fs::remove_dir_all(&path);
        fs::create_dir_all(&path).unwrap();
        Self(path)
    }

    fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

fn input(client: u64, tick: u64) -> LegacyInput {
    LegacyInput {
        sequence: tick as u32,
        tick,
        movement: [(client as f32) * 0.5 - 1.0, 0.25],
        yaw: tick as f32 * 0.01,
        buttons: (tick % 4) as u8,
        view_behind: 0.0,
    }
}

/// A session: a start, then per tick an inputs record and a hash, with a
/// keyframe of `state_bytes` bytes every `keyframe_every` ticks.
fn session(ticks: u64, keyframe_every: u64, state_bytes: usize) -> Vec<Record> {
    let mut out = vec![Record::SessionStart {
        tick: 0,
        tick_hz: 60,
        scene: "demo".into(),
    }];
    for tick in 0..ticks {
        if tick % keyframe_every == 0 {
            out.push(Record::Keyframe {
                tick,
                state: (0..state_bytes).map(|i| (i as u64 ^ tick) as u8).collect(),
            });
        }
        if tick % 3 != 2 {
            out.push(Record::Inputs {
                tick,
                inputs: vec![(1, input(1, tick)), (2, input(2, tick))],
            });
        }
        if tick % 5 == 4 {
            out.push(Record::AdminEdit {
                tick,
                who: "ops".into(),
                what: vec![tick as u8; 3],
            });
        }
        out.push(Record::TickHash {
            tick,
            hash: tick.wrapping_mul(0x9E37_79B9_7F4A_7C15),
        });
    }
    out
}

fn small_segments() -> RecordOptions {
    RecordOptions {
        segment_bytes: 2_000,
    }
}

fn write_all(dir: &Path, records: &[Record], options: RecordOptions) -> RecordWriter {
    let mut writer = RecordWriter::open(dir, options).unwrap();
    for r in records {
        writer.append(r).unwrap();
    }
    writer.flush().unwrap();
    writer
}

fn read_all(path: &Path) -> Vec<Record> {
    RecordReader::open(path)
        .unwrap()
        .iter()
        .collect::<Result<_, _>>()
        .unwrap()
}

/// Every record a salvaging read delivers (reading past damage).
fn salvage_all(path: &Path) -> Vec<Record> {
    RecordReader::open(path)
        .unwrap()
        .salvage()
        .filter_map(|r| match r.unwrap() {
            Salvaged::Record { record, .. } => Some(record),
            Salvaged::Damaged { .. } | Salvaged::TornTail(_) => None,
        })
        .collect()
}

/// Appends and syncs `record`; returns the newest segment and the byte
/// range of the record's frame in it.
fn append_tracked(writer: &mut RecordWriter, record: &Record) -> (PathBuf, u64, u64) {
    writer.append(record).unwrap();
    writer.flush().unwrap();
    let newest = writer.segments().last().unwrap().clone();
    let len = fs::metadata(&newest.path).unwrap().len();
    assert_eq!(len, newest.bytes);
    let frame = 9 + record.payload_len();
    (newest.path, len - frame, len)
}

#[test]
fn every_record_kind_round_trips_through_files() {
    let dir = TempDir::new("round-trip");
    let records = vec![
        Record::SessionStart {
            tick: 3,
            tick_hz: 120,
            scene: "scènes/arena.ron".into(),
        },
        Record::Keyframe {
            tick: 3,
            state: (0..10_000u32).map(|i| (i * 31) as u8).collect(),
        },
        Record::Inputs {
            tick: 4,
            inputs: vec![(7, input(7, 4)), (u64::MAX, input(9, 4))],
        },
        Record::Inputs {
            tick: 4,
            inputs: vec![],
        },
        Record::TickHash {
            tick: 4,
            hash: u64::MAX,
        },
        Record::AdminEdit {
            tick: 5,
            who: "admin".into(),
            what: b"set gravity 0 -3.7 0".to_vec(),
        },
        Record::Keyframe {
            tick: 6,
            state: vec![],
        },
    ];
    drop(write_all(dir.path(), &records, RecordOptions::default()));
    assert_eq!(read_all(dir.path()), records);

    // Reopening finds everything intact and carries on after it.
    let mut writer = RecordWriter::open(dir.path(), RecordOptions::default()).unwrap();
    let report = writer.open_report().clone();
    assert_eq!(report.cut, None);
    assert_eq!(report.bytes_cut(), 0);
    assert_eq!(report.last_tick, Some(6));
    assert_eq!(report.records_in_newest, records.len() as u64);
    let more = Record::TickHash { tick: 6, hash: 1 };
    writer.append(&more).unwrap();
    writer.flush().unwrap();
    let mut expected = records.clone();
    expected.push(more);
    assert_eq!(read_all(dir.path()), expected);

    // A single segment file opens on its own too.
    let file = writer.segments()[0].path.clone();
    assert_eq!(read_all(&file), expected);
}

#[test]
fn segments_roll_over_at_keyframes_only() {
    let dir = TempDir::new("roll-over");
    let records = session(200, 20, 600);
    let writer = write_all(dir.path(), &records, small_segments());
    let files = writer.segments().to_vec();
    assert!(files.len() >= 5, "{} segments", files.len());
    drop(writer);

    let reader = RecordReader::open(dir.path()).unwrap();
    let infos = reader.segments().unwrap();
    assert_eq!(infos.len(), files.len());
    for (i, (info, file)) in infos.iter().zip(&files).enumerate() {
        assert_eq!(info.path, file.path);
        assert_eq!(info.first_tick, file.first_tick);
        assert_eq!(
            file.path.file_name().unwrap().to_str().unwrap(),
            format!("segment-{:020}.irec", info.first_tick)
        );
        assert_eq!(info.bytes, fs::metadata(&file.path).unwrap().len());
        let own = read_all(&file.path);
        assert_eq!(own.len() as u64, info.records);
        assert_eq!(own.last().unwrap().tick(), info.last_tick);
        if i > 0 {
            assert!(matches!(own[0], Record::Keyframe { tick, .. } if tick == info.first_tick));
            // The previous segment had reached the size before rolling.
            assert!(infos[i - 1].bytes >= small_segments().segment_bytes);
            assert!(infos[i - 1].last_tick <= info.first_tick);
        }
    }
    assert_eq!(read_all(dir.path()), records);
}

#[test]
fn lookups_agree_with_a_plain_scan() {
    let dir = TempDir::new("lookups");
    let records = session(150, 10, 300);
    drop(write_all(dir.path(), &records, small_segments()));
    let reader = RecordReader::open(dir.path()).unwrap();
    assert!(reader.segment_files().len() > 3);

    for tick in [0, 1, 9, 10, 11, 59, 60, 61, 99, 149, 150, 10_000] {
        let keyframe = records.iter().rev().find_map(|r| match r {
            Record::Keyframe { tick: t, state } if *t <= tick => Some((*t, state.clone())),
            _ => None,
        });
        assert_eq!(
            reader.keyframe_at_or_before(tick).unwrap(),
            keyframe,
            "{tick}"
        );

        let hash = records.iter().find_map(|r| match r {
            Record::TickHash { tick: t, hash } if *t == tick => Some(*hash),
            _ => None,
        });
        assert_eq!(reader.hash_at(tick).unwrap(), hash, "{tick}");

        // iter_from starts with the keyframe a replay to `tick` restores,
        // then runs to the end.
        let from: Vec<Record> = reader.iter_from(tick).collect::<Result<_, _>>().unwrap();
        let start = records.len() - from.len();
        assert_eq!(from, records[start..]);
        if start > 0 {
            match &from[0] {
                Record::Keyframe { tick: t, .. } => assert!(*t <= tick),
                other => panic!("segment starts with {other:?}"),
            }
        }
    }

    for (a, b) in [(0, 0), (0, 149), (37, 64), (40, 40), (42, 41), (140, 500)] {
        let expected: Vec<_> = records
            .iter()
            .filter_map(|r| match r {
                Record::Inputs { tick, inputs } if (a..=b).contains(tick) => {
                    Some((*tick, inputs.clone()))
                }
                _ => None,
            })
            .collect();
        assert_eq!(reader.inputs_between(a, b).unwrap(), expected, "{a}..={b}");
    }
}

#[test]
fn records_at_a_segment_boundary_tick_are_all_found() {
    // The hash and inputs of tick 10 are written before the keyframe of
    // tick 10 that starts the next segment.
    let dir = TempDir::new("boundary");
    let options = RecordOptions { segment_bytes: 1 };
    let mut writer = RecordWriter::open(dir.path(), options).unwrap();
    let records = vec![
        Record::Keyframe {
            tick: 0,
            state: vec![1],
        },
        Record::Inputs {
            tick: 10,
            inputs: vec![(1, input(1, 10))],
        },
        Record::TickHash { tick: 10, hash: 77 },
        Record::Keyframe {
            tick: 10,
            state: vec![2],
        },
        Record::TickHash { tick: 11, hash: 78 },
    ];
    for r in &records {
        writer.append(r).unwrap();
    }
    writer.flush().unwrap();
    assert_eq!(writer.segments().len(), 2);
    let reader = RecordReader::open(dir.path()).unwrap();
    assert_eq!(reader.hash_at(10).unwrap(), Some(77));
    assert_eq!(reader.inputs_between(10, 10).unwrap().len(), 1);
    assert_eq!(
        reader.keyframe_at_or_before(10).unwrap(),
        Some((10, vec![2]))
    );
    assert_eq!(reader.keyframe_at_or_before(9).unwrap(), Some((0, vec![1])));
}

/// Writes `base`, then `last` as the newest record, and returns the newest
/// segment's path and the last frame's byte range in it.
fn torn_fixture(dir: &Path, base: &[Record], last: &Record) -> (PathBuf, u64, u64) {
    let mut writer = write_all(dir, base, small_segments());
    append_tracked(&mut writer, last)
}

fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files: Vec<_> = fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            let bytes = fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect();
    files.sort();
    files
}

fn restore(dir: &Path, files: &[(PathBuf, Vec<u8>)]) {
    for e in fs::read_dir(dir).unwrap() {
        fs::remove_file(e.unwrap().path()).unwrap();
    }
    for (p, bytes) in files {
        fs::write(p, bytes).unwrap();
    }
}

/// Cuts the last frame short at each of its bytes, then garbles each of its
/// bytes. Cut short, it is a torn tail: the reader never panics or
/// delivers it, the writer cuts exactly that frame, keeping its bytes
/// aside, and appending continues after it. Garbled, it is damage (unless
/// the garbling made it look cut short): the writer leaves the segment as
/// it is and appends in a new segment.
fn check_torn_tail(name: &str, base: Vec<Record>, last: Record) {
    let dir = TempDir::new(name);
    let (newest, start, end) = torn_fixture(dir.path(), &base, &last);
    let pristine = snapshot(dir.path());
    let next = Record::TickHash {
        tick: last.tick() + 1,
        hash: 0xABCD,
    };
    let mut expected = base.clone();
    expected.push(next.clone());

    // The newest segment is cut exactly at the start of the damaged frame,
    // and what was cut is kept beside it.
    let check_repaired = |report: &OpenReport, damaged: &[u8]| {
        let cut = report.cut.as_ref().expect("a torn tail is cut");
        assert_eq!(cut.path, newest);
        assert_eq!(cut.offset, start);
        assert_eq!(cut.bytes_cut, damaged.len() as u64 - start);
        assert!(cut.why.is_torn_write(), "{:?}", cut.why);
        let mut aside = newest.as_os_str().to_owned();
        aside.push(format!(".torn-{start}"));
        assert_eq!(cut.kept_at, PathBuf::from(aside));
        assert_eq!(fs::read(&cut.kept_at).unwrap(), &damaged[start as usize..]);
        assert_eq!(report.damaged, None);
        assert_eq!(report.last_tick, base.last().map(Record::tick));
    };

    // Cut at every byte of the last frame.
    for cut_at in start..end {
        restore(dir.path(), &pristine);
        let file = fs::OpenOptions::new().write(true).open(&newest).unwrap();
        file.set_len(cut_at).unwrap();
        drop(file);
        let damaged = fs::read(&newest).unwrap();

        // Before repair a reader sees the intact records, then a clean end.
        assert_eq!(read_all(dir.path()), base, "cut at {cut_at}");

        let mut writer = RecordWriter::open(dir.path(), small_segments()).unwrap();
        let report = writer.open_report().clone();
        if cut_at == start {
            assert_eq!(report.cut, None, "a cut at a frame boundary is intact");
        } else {
            check_repaired(&report, &damaged);
        }
        writer.append(&next).unwrap();
        writer.flush().unwrap();
        drop(writer);
        assert_eq!(read_all(dir.path()), expected, "cut at {cut_at}");
    }

    // Flip every byte of the last frame, one at a time.
    for at in start..end {
        restore(dir.path(), &pristine);
        let mut bytes = fs::read(&newest).unwrap();
        bytes[at as usize] ^= 0x5A;
        fs::write(&newest, &bytes).unwrap();

        // A reader either ends cleanly or reports the damage; never panics,
        // never delivers the damaged record.
        let got: Vec<_> = RecordReader::open(dir.path()).unwrap().iter().collect();
        let ok: Vec<Record> = got
            .iter()
            .filter_map(|r| r.as_ref().ok().cloned())
            .collect();
        assert_eq!(ok, base, "flip at {at}");

        let mut writer = RecordWriter::open(dir.path(), small_segments()).unwrap();
        let report = writer.open_report().clone();
        let segments = writer.segments().len();
        if report.cut.is_some() {
            // A length flipped upward: it now runs past the end, with
            // nothing intact after it.
            assert!((1..5).contains(&(at - start)), "flip at {at}");
            check_repaired(&report, &bytes);
        } else {
            let damaged = report.damaged.clone().expect("damage is reported");
            assert_eq!(damaged.path, newest, "flip at {at}");
            assert_eq!(damaged.offset, start, "flip at {at}");
            assert!(
                !damaged.why.is_torn_write(),
                "flip at {at}: {:?}",
                damaged.why
            );
        }
        writer.append(&next).unwrap();
        writer.flush().unwrap();
        if report.cut.is_none() {
            assert_eq!(writer.segments().len(), segments + 1, "a new segment");
            assert_eq!(fs::read(&newest).unwrap(), bytes, "left as it is");
        }
        drop(writer);
        assert_eq!(salvage_all(dir.path()), expected, "flip at {at}");
    }
}

#[test]
fn torn_tail_of_a_small_record_is_cut_and_appending_continues() {
    let base = session(30, 10, 100);
    let last = Record::Inputs {
        tick: 30,
        inputs: vec![(3, input(3, 30))],
    };
    check_torn_tail("torn-inputs", base, last);
}

#[test]
fn torn_keyframe_that_started_a_segment_removes_the_segment() {
    // With 2000-byte segments and 600-byte states the keyframe at 40 starts
    // a new segment (its own size does not matter); cutting it leaves that
    // segment empty, and open removes it and goes on appending to the one
    // before.
    let base = session(40, 20, 600);
    let last = Record::Keyframe {
        tick: 40,
        state: vec![0xEE; 120],
    };
    let dir = TempDir::new("torn-keyframe-probe");
    let mut writer = write_all(dir.path(), &base, small_segments());
    let before = writer.segments().len();
    writer.append(&last).unwrap();
    assert_eq!(
        writer.segments().len(),
        before + 1,
        "the keyframe rolls over"
    );
    drop(writer);
    drop(dir);

    check_torn_tail("torn-keyframe", base.clone(), last.clone());

    // And the removal is reported.
    let dir = TempDir::new("torn-keyframe-report");
    let (newest, start, _) = torn_fixture(dir.path(), &base, &last);
    assert_eq!(start, 8, "the keyframe is the segment's first frame");
    let file = fs::OpenOptions::new().write(true).open(&newest).unwrap();
    file.set_len(start + 50).unwrap();
    drop(file);
    let writer = RecordWriter::open(dir.path(), small_segments()).unwrap();
    let report = writer.open_report();
    assert_eq!(report.removed, vec![newest.clone()]);
    assert_eq!(report.bytes_cut(), 50);
    assert!(!newest.exists());
    assert_eq!(report.segments, before);
}

#[test]
fn torn_segment_header_is_cut() {
    let dir = TempDir::new("torn-header");
    let base = session(10, 5, 10);
    drop(write_all(dir.path(), &base, RecordOptions::default()));
    // A crash just after creating the next segment, mid-header.
    let path = dir.path().join("segment-00000000000000000100.irec");
    fs::write(&path, b"IRE").unwrap();
    assert_eq!(read_all(dir.path()), base);
    let mut writer = RecordWriter::open(dir.path(), RecordOptions::default()).unwrap();
    assert_eq!(writer.open_report().removed, vec![path]);
    assert_eq!(writer.open_report().bytes_cut(), 3);
    let next = Record::TickHash { tick: 10, hash: 1 };
    writer.append(&next).unwrap();
    writer.flush().unwrap();
    let mut expected = base;
    expected.push(next);
    assert_eq!(read_all(dir.path()), expected);
}

#[test]
fn corruption_in_an_older_segment_is_reported_with_its_offset() {
    let dir = TempDir::new("corrupt-middle");
    let mut writer = RecordWriter::open(dir.path(), small_segments()).unwrap();
    let records = session(100, 20, 600);
    // Where each record's frame starts, per segment.
    let mut offsets = Vec::new();
    for r in &records {
        writer.append(r).unwrap();
        let seg = writer.segments().last().unwrap();
        let end = seg.bytes;
        offsets.push((seg.path.clone(), end - 9 - r.payload_len()));
    }
    writer.flush().unwrap();
    let segments = writer.segments().to_vec();
    assert!(segments.len() >= 3);
    drop(writer);

    // A record in the middle of the first segment.
    let in_first: Vec<_> = offsets
        .iter()
        .enumerate()
        .filter(|(_, (p, _))| *p == segments[0].path)
        .collect();
    let (index, (path, offset)) = in_first[in_first.len() / 2];
    let (path, offset) = (path.clone(), *offset);
    let mut bytes = fs::read(&path).unwrap();
    bytes[offset as usize + 6] ^= 0xFF; // inside the payload
    fs::write(&path, &bytes).unwrap();

    let reader = RecordReader::open(dir.path()).unwrap();
    let got: Vec<_> = reader.iter().collect();
    assert_eq!(got.len(), index + 1, "stops at the damage, skips nothing");
    for (r, want) in got.iter().zip(&records) {
        if let Ok(r) = r {
            assert_eq!(r, want);
        }
    }
    match got.last().unwrap() {
        Err(RecordError::Corrupt {
            path: p,
            offset: o,
            why: Corruption::BadChecksum { .. },
        }) => {
            assert_eq!(p, &path);
            assert_eq!(*o, offset);
        }
        other => panic!("expected Corrupt, got {other:?}"),
    }
    assert!(matches!(
        reader.segments(),
        Err(RecordError::Corrupt { offset: o, .. }) if o == offset
    ));
    // A lookup that has to read through it fails the same way...
    assert!(matches!(
        reader.keyframe_at_or_before(segments[0].first_tick + 15),
        Err(RecordError::Corrupt { .. })
    ));
    // ...while one that starts in a later segment does not read it.
    assert!(reader.hash_at(99).unwrap().is_some());

    // The writer only repairs the newest segment: it opens and appends
    // without touching the damaged one.
    let mut writer = RecordWriter::open(dir.path(), small_segments()).unwrap();
    assert_eq!(writer.open_report().cut, None);
    writer
        .append(&Record::TickHash { tick: 100, hash: 0 })
        .unwrap();
    writer.flush().unwrap();
    assert_eq!(fs::read(&path).unwrap(), bytes);
}

#[test]
fn checksummed_garbage_in_the_newest_segment_is_not_cut() {
    // A frame with a valid checksum but a kind this build does not know
    // (a newer format?) is not a torn write: keep it, append after it in a
    // new segment.
    let dir = TempDir::new("unknown-kind");
    let records = session(5, 5, 10);
    let writer = write_all(dir.path(), &records, RecordOptions::default());
    let newest = writer.segments().last().unwrap().path.clone();
    drop(writer);
    let mut frame = vec![42u8, 0, 0, 0, 0];
    let crc = inertia_server::record::crc32::crc32(&frame);
    frame.extend_from_slice(&crc.to_le_bytes());
    let mut bytes = fs::read(&newest).unwrap();
    let offset = bytes.len() as u64;
    bytes.extend_from_slice(&frame);
    fs::write(&newest, &bytes).unwrap();
    let mut writer = RecordWriter::open(dir.path(), RecordOptions::default()).unwrap();
    assert_eq!(
        writer.open_report().damaged,
        Some(SegmentDamage {
            path: newest.clone(),
            offset,
            why: Corruption::UnknownKind(42),
        })
    );
    assert_eq!(writer.open_report().cut, None);
    assert_eq!(fs::read(&newest).unwrap(), bytes);
    assert!(!writer.can_append_at(3), "before the last intact record");
    let next = Record::TickHash { tick: 5, hash: 1 };
    assert!(writer.can_append_at(5));
    writer.append(&next).unwrap();
    writer.flush().unwrap();
    assert_eq!(writer.segments().len(), 2);
    assert_eq!(
        writer.segments()[1]
            .path
            .file_name()
            .unwrap()
            .to_string_lossy(),
        "segment-00000000000000000005.irec"
    );
    drop(writer);
    assert_eq!(fs::read(&newest).unwrap(), bytes);
    let mut expected = records;
    expected.push(next);
    assert_eq!(salvage_all(dir.path()), expected);
    // The strict reader reports the damage, now in an older segment.
    assert!(matches!(
        RecordReader::open(dir.path()).unwrap().iter().last(),
        Some(Err(RecordError::Corrupt { offset: o, why: Corruption::UnknownKind(42), .. })) if o == offset
    ));
}

#[test]
fn a_new_segment_never_takes_the_name_of_a_damaged_one() {
    // The damaged newest segment holds records of its first tick only: a
    // segment for that tick would take its name. Refused, nothing written.
    let dir = TempDir::new("name-taken");
    let first = Record::Keyframe {
        tick: 9,
        state: vec![1; 20],
    };
    let writer = write_all(
        dir.path(),
        std::slice::from_ref(&first),
        RecordOptions::default(),
    );
    let newest = writer.segments()[0].path.clone();
    drop(writer);
    let mut bytes = fs::read(&newest).unwrap();
    bytes.extend_from_slice(&[3, 0, 0, 0, 0, 0, 0, 0, 0, 7]);
    fs::write(&newest, &bytes).unwrap();
    let mut writer = RecordWriter::open(dir.path(), RecordOptions::default()).unwrap();
    assert!(writer.open_report().damaged.is_some());
    assert!(!writer.can_append_at(9));
    assert!(matches!(
        writer.append(&Record::TickHash { tick: 9, hash: 1 }),
        Err(RecordError::DamagedSegmentInTheWay { tick: 9, .. })
    ));
    let next = Record::TickHash { tick: 10, hash: 1 };
    assert!(writer.can_append_at(10));
    writer.append(&next).unwrap();
    writer.flush().unwrap();
    drop(writer);
    assert_eq!(fs::read(&newest).unwrap(), bytes);
    assert_eq!(salvage_all(dir.path()), vec![first, next]);
}

#[test]
fn a_length_corrupted_past_the_end_with_records_after_it_is_damage() {
    // A bit flipped in a record's length can make it run past the end of
    // the file like a torn record; the intact records after it say it is
    // damage, and nothing is cut.
    let dir = TempDir::new("long-length");
    let records = session(30, 10, 100);
    let mut writer = RecordWriter::open(dir.path(), RecordOptions::default()).unwrap();
    let mut frames = Vec::new();
    for r in &records {
        frames.push(append_tracked(&mut writer, r));
    }
    drop(writer);
    let (path, start, _) = frames[frames.len() / 2].clone();
    let mut bytes = fs::read(&path).unwrap();
    bytes[start as usize + 3] ^= 0x01; // + 64 KiB
    fs::write(&path, &bytes).unwrap();
    let writer = RecordWriter::open(dir.path(), RecordOptions::default()).unwrap();
    let damaged = writer.open_report().damaged.clone().expect("damage");
    assert_eq!(
        (damaged.offset, damaged.why),
        (start, Corruption::Truncated)
    );
    assert_eq!(writer.open_report().cut, None);
    drop(writer);
    assert_eq!(fs::read(&path).unwrap(), bytes);
    assert!(matches!(
        RecordReader::open(dir.path()).unwrap().iter().last(),
        Some(Err(RecordError::Corrupt { offset: o, why: Corruption::Truncated, .. })) if o == start
    ));
}

#[test]
fn retention_removes_the_oldest_segments_and_keeps_the_newest() {
    let dir = TempDir::new("retention");
    let records = session(300, 20, 600);
    let mut writer = write_all(dir.path(), &records, small_segments());
    let all = writer.segments().to_vec();
    assert!(all.len() >= 6);
    let total: u64 = all.iter().map(|s| s.bytes).sum();
    assert_eq!(writer.total_bytes(), total);

    // Under the limit: nothing goes.
    assert!(writer.enforce_retention(total).unwrap().is_empty());

    // Room for about half: the oldest go, in order, until it fits.
    let limit = total / 2;
    let removed = writer.enforce_retention(limit).unwrap();
    assert!(!removed.is_empty());
    assert_eq!(removed, all[..removed.len()]);
    assert!(writer.total_bytes() <= limit);
    assert!(writer.total_bytes() + removed.last().unwrap().bytes > limit);
    for r in &removed {
        assert!(!r.path.exists());
    }
    assert_eq!(writer.segments(), &all[removed.len()..]);

    // What is left still replays from its first segment's keyframe.
    let reader = RecordReader::open(dir.path()).unwrap();
    let first = writer.segments()[0].first_tick;
    let kept: Vec<Record> = reader.iter().collect::<Result<_, _>>().unwrap();
    assert!(matches!(kept[0], Record::Keyframe { tick, .. } if tick == first));
    assert_eq!(kept[..], records[records.len() - kept.len()..]);
    assert_eq!(reader.keyframe_at_or_before(first - 1).unwrap(), None);

    // A limit of 0 still keeps the segment being written, and appending
    // goes on.
    let newest = all.last().unwrap().clone();
    writer.enforce_retention(0).unwrap();
    assert_eq!(writer.segments(), std::slice::from_ref(&newest));
    assert!(newest.path.exists());
    writer
        .append(&Record::TickHash { tick: 300, hash: 3 })
        .unwrap();
    writer.flush().unwrap();
    let reopened = RecordWriter::open(dir.path(), small_segments()).unwrap();
    assert_eq!(reopened.segments().len(), 1);
    assert_eq!(reopened.last_tick(), Some(300));
}

#[test]
fn refused_appends_write_nothing_and_leave_the_writer_usable() {
    let dir = TempDir::new("refusals");
    let mut writer = RecordWriter::open(dir.path(), RecordOptions::default()).unwrap();
    writer
        .append(&Record::TickHash { tick: 10, hash: 1 })
        .unwrap();
    assert!(matches!(
        writer.append(&Record::TickHash { tick: 9, hash: 1 }),
        Err(RecordError::TickBackwards { last: 10, got: 9 })
    ));
    let huge = Record::Keyframe {
        tick: 11,
        state: vec![0; MAX_RECORD_BYTES as usize],
    };
    assert!(matches!(
        writer.append(&huge),
        Err(RecordError::TooLarge { .. })
    ));
    writer
        .append(&Record::TickHash { tick: 10, hash: 2 })
        .unwrap();
    writer.flush().unwrap();
    drop(writer);
    assert_eq!(
        read_all(dir.path()),
        vec![
            Record::TickHash { tick: 10, hash: 1 },
            Record::TickHash { tick: 10, hash: 2 }
        ]
    );
    // The last tick survives reopening.
    let mut writer = RecordWriter::open(dir.path(), RecordOptions::default()).unwrap();
    assert!(matches!(
        writer.append(&Record::TickHash { tick: 3, hash: 1 }),
        Err(RecordError::TickBackwards { last: 10, got: 3 })
    ));
}

#[test]
fn an_empty_directory_reads_as_nothing_and_other_files_are_ignored() {
    let dir = TempDir::new("empty");
    fs::write(dir.path().join("dev-credentials.json"), b"{}").unwrap();
    let reader = RecordReader::open(dir.path()).unwrap();
    assert!(reader.segment_files().is_empty());
    assert_eq!(reader.iter().count(), 0);
    assert_eq!(reader.keyframe_at_or_before(5).unwrap(), None);
    assert_eq!(reader.hash_at(5).unwrap(), None);
    assert!(reader.inputs_between(0, 5).unwrap().is_empty());
    let writer = RecordWriter::open(dir.path(), RecordOptions::default()).unwrap();
    assert_eq!(writer.open_report(), &OpenReport::default());
    assert!(writer.segments().is_empty());
    assert!(matches!(
        RecordReader::open(dir.path().join("missing")),
        Err(RecordError::Io { .. })
    ));
}

fn exercise_reader(path: &Path) {
    let Ok(reader) = RecordReader::open(path) else {
        return;
    };
    let _ = reader.segments();
    for r in reader.iter().take(10_000) {
        let _ = r;
    }
    let _ = reader.keyframe_at_or_before(u64::MAX);
    let _ = reader.hash_at(3);
    let _ = reader.inputs_between(0, u64::MAX);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn random_bytes_as_a_segment_never_panic(
        bytes in proptest::collection::vec(any::<u8>(), 0..600),
        with_header in any::<bool>(),
    ) {
        let dir = TempDir::new("fuzz-bytes");
        let path = dir.path().join("segment-00000000000000000000.irec");
        let mut content = if with_header { b"IREC\x01\x00\x00\x00".to_vec() } else { Vec::new() };
        content.extend_from_slice(&bytes);
        fs::write(&path, &content).unwrap();
        exercise_reader(&path);
        exercise_reader(dir.path());
        // The writer either repairs a torn tail, after which the file reads
        // back without error, or leaves a damaged file exactly as it was.
        let writer = RecordWriter::open(dir.path(), RecordOptions::default()).unwrap();
        if writer.open_report().damaged.is_some() {
            prop_assert_eq!(fs::read(&path).unwrap(), content);
        } else if path.exists() {
            prop_assert!(RecordReader::open(&path).unwrap().iter().all(|r| r.is_ok()));
        }
    }

    #[test]
    fn mutated_segments_never_panic(
        flips in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
        cut in any::<prop::sample::Index>(),
    ) {
        let dir = TempDir::new("fuzz-mutate");
        let writer = write_all(dir.path(), &session(12, 4, 40), RecordOptions::default());
        let path = writer.segments()[0].path.clone();
        drop(writer);
        let mut bytes = fs::read(&path).unwrap();
        for (at, x) in flips {
            let i = at.index(bytes.len());
            bytes[i] ^= x;
        }
        bytes.truncate(cut.index(bytes.len() + 1));
        fs::write(&path, &bytes).unwrap();
        exercise_reader(dir.path());
        let _ = RecordWriter::open(dir.path(), RecordOptions::default());
    }
}

proptest! {
    // Each case syncs every segment it starts: fewer cases.
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn written_sessions_read_back(
        ticks in 1u64..80,
        keyframe_every in 1u64..15,
        state_bytes in 0usize..400,
        segment_bytes in 1u64..3_000,
    ) {
        let dir = TempDir::new("fuzz-session");
        let records = session(ticks, keyframe_every, state_bytes);
        let writer = write_all(dir.path(), &records, RecordOptions { segment_bytes });
        for s in writer.segments() {
            prop_assert_eq!(s.bytes, fs::metadata(&s.path).unwrap().len());
        }
        drop(writer);
        prop_assert_eq!(read_all(dir.path()), records);
    }
}
