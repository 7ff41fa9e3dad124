//! `--resume` on a damaged recording (issue 11): only a genuine torn tail
//! (an incomplete last record at the end of the newest segment) is cut,
//! and its bytes are kept aside first; damage anywhere is reported and
//! left as it is, and resume carries on from the newest intact keyframe
//! before it. A keyframe whose checksum holds but whose content does not
//! decode is damage too: resume falls back to the keyframe before it.

use crate::common;
use inertia_protocol::input::GameInput;

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use common::FLAT;
use inertia_protocol::PlayerInput;
use inertia_server::record::compress::{pack, unpack};
use inertia_server::record::crc32::crc32;
use inertia_server::record::{RecordReader, RecorderConfig};
use inertia_server::replay::{DamageKind, DEFAULT_KEYFRAME_BUDGET};
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::resume::{read_for_resume, ResumeError, ResumeReport};
use inertia_server::sim::{SimConfig, Simulation};

/// Record kinds, as their bytes on disk.
const KEYFRAME: u8 = 2;
const TICK_HASH: u8 = 4;

/// A fresh scratch directory (removed on drop).
struct Scratch(PathBuf);

impl Scratch {
    fn new(what: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("inertia-issue-11-{what}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("scratch directory");
        Scratch(dir)
    }

    fn recording(&self) -> PathBuf {
        self.0.join("recording")
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

fn config(dir: &Path, keyframe_ticks: u64, segment_bytes: u64, record: bool) -> SimConfig {
    SimConfig {
        recording: Some(RecorderConfig {
            keyframe_ticks,
            segment_bytes,
            ..RecorderConfig::new(dir)
        }),
        record_at_start: record,
        ..SimConfig::default()
    }
}

fn simulation(config: SimConfig) -> Simulation {
    let built = Scene::parse(FLAT, SceneFormat::Ron)
        .unwrap()
        .build()
        .unwrap();
    Simulation::new(built, Box::new(SandboxRules::default()), config)
}

/// Records `ticks` ticks of the flat scene into `dir` (a client joins and
/// sends an input before every third tick), ending with the shutdown
/// keyframe.
fn record(dir: &Path, ticks: u64, keyframe_ticks: u64, segment_bytes: u64) {
    let mut s = simulation(config(dir, keyframe_ticks, segment_bytes, true));
    s.join(7).unwrap();
    drive(&mut s, ticks);
    s.finish_recording();
}

/// Runs `ticks` ticks, client 7 sending an input before every third.
fn drive(s: &mut Simulation, ticks: u64) {
    for i in 0..ticks {
        if i % 3 == 0 {
            let input = PlayerInput {
                sequence: (s.world().tick() / 3 + 1) as u32,
                tick: s.world().tick(),
                payload: inertia_sandbox::SandboxInput {
                    movement: [((i % 50) as f32 / 50.0), 0.5],
                    yaw: 0.25,
                    buttons: 0,
                }
                .to_payload(),
                view_behind: 0.0,
            };
            let _ = s.input(7, &input);
        }
        s.run_ticks(1);
    }
}

/// Resumes a fresh simulation from the recording at `dir` as the server
/// does.
fn resume(dir: &Path) -> Result<(Simulation, ResumeReport), ResumeError> {
    let mut s = simulation(config(dir, 30, 64 * 1024 * 1024, false));
    let plan = read_for_resume(dir, DEFAULT_KEYFRAME_BUDGET)?;
    let report = s.resume(plan)?;
    Ok((s, report))
}

/// Every file in `dir`, by name, with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                fs::read(e.path()).unwrap(),
            )
        })
        .collect()
}

/// Fails, naming each file and its length, unless `dir` holds exactly
/// `before`.
fn assert_same_files(dir: &Path, before: &BTreeMap<String, Vec<u8>>, what: &str) {
    let now = snapshot(dir);
    let lengths = |m: &BTreeMap<String, Vec<u8>>| -> Vec<(String, usize)> {
        m.iter().map(|(n, b)| (n.clone(), b.len())).collect()
    };
    assert!(
        now == *before,
        "{what}: before {:?}, now {:?}",
        lengths(before),
        lengths(&now)
    );
}

/// The segment files of `dir`, oldest first.
fn segments(dir: &Path) -> Vec<PathBuf> {
    RecordReader::open(dir)
        .unwrap()
        .segment_files()
        .iter()
        .map(|s| s.path.clone())
        .collect()
}

/// One frame of a segment file, found by walking the framing.
#[derive(Debug, Clone, Copy)]
struct Frame {
    /// Byte offset of its kind byte.
    offset: usize,
    kind: u8,
    /// Payload bytes.
    len: usize,
}

impl Frame {
    fn end(&self) -> usize {
        self.offset + 9 + self.len
    }

    fn payload<'a>(&self, bytes: &'a [u8]) -> &'a [u8] {
        &bytes[self.offset + 5..self.offset + 5 + self.len]
    }

    fn tick(&self, bytes: &[u8]) -> u64 {
        u64::from_le_bytes(self.payload(bytes)[..8].try_into().unwrap())
    }

    fn contains(&self, at: usize) -> bool {
        self.offset <= at && at < self.end()
    }
}

fn frames(bytes: &[u8]) -> Vec<Frame> {
    let mut out = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() {
        let len = u32::from_le_bytes(bytes[at + 1..at + 5].try_into().unwrap()) as usize;
        if at + 9 + len > bytes.len() {
            break;
        }
        out.push(Frame {
            offset: at,
            kind: bytes[at],
            len,
        });
        at += 9 + len;
    }
    out
}

/// A whole frame of `kind` around `payload`, its checksum right.
fn frame_bytes(kind: u8, payload: &[u8]) -> Vec<u8> {
    let mut out = vec![kind];
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(payload);
    let crc = crc32(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// `bytes` with `frame` replaced by `replacement`.
fn replace_frame(bytes: &[u8], frame: Frame, replacement: &[u8]) -> Vec<u8> {
    let mut out = bytes[..frame.offset].to_vec();
    out.extend_from_slice(replacement);
    out.extend_from_slice(&bytes[frame.end()..]);
    out
}

/// The last tick hashed before byte `before`.
fn last_hash_before(bytes: &[u8], before: usize) -> u64 {
    frames(bytes)
        .iter()
        .filter(|f| f.kind == TICK_HASH && f.end() <= before)
        .map(|f| f.tick(bytes))
        .max()
        .expect("a hash before the damage")
}

/// Ticks of the keyframes wholly before byte `before`.
fn keyframes_before(bytes: &[u8], before: usize) -> Vec<u64> {
    frames(bytes)
        .iter()
        .filter(|f| f.kind == KEYFRAME && f.end() <= before)
        .map(|f| f.tick(bytes))
        .collect()
}

/// Files in `dir` that are not segments, by name.
fn kept_aside(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    snapshot(dir)
        .into_iter()
        .filter(|(name, _)| !name.ends_with(".irec"))
        .collect()
}

fn admin(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_inertia-admin"))
        .args(args)
        .output()
        .expect("inertia-admin runs")
}

#[test]
fn issue_44_a_flipped_bit_inside_the_newest_segment_keeps_it_whole_and_resumes_past_it() {
    let scratch = Scratch::new("flip");
    let dir = scratch.recording();
    record(&dir, 1500, 5, 64 * 1024 * 1024);
    let files = segments(&dir);
    assert_eq!(files.len(), 1, "one segment");
    let path = &files[0];
    let mut bytes = fs::read(path).unwrap();
    // The record about 1 % into the segment gets a flipped bit in its
    // payload: its checksum fails, with almost the whole segment after it.
    let at = bytes.len() / 100;
    let hit = *frames(&bytes).iter().find(|f| f.contains(at)).unwrap();
    let newest = *keyframes_before(&bytes, bytes.len()).last().unwrap();
    let durable = last_hash_before(&bytes, bytes.len()).max(newest);
    assert!(
        keyframes_before(&bytes, hit.offset).last() < Some(&newest),
        "keyframes after the damage"
    );
    bytes[hit.offset + 5 + hit.len / 2] ^= 0x10;
    fs::write(path, &bytes).unwrap();
    let before = snapshot(&dir);

    // Reading goes on at the record after the damaged one: the resume
    // carries on from the newest keyframe, past the damage.
    let (mut sim, report) = resume(&dir).expect("resume carries on past the damage");
    println!("{report:?}");
    assert_eq!(report.keyframe_tick, newest);
    assert_eq!(report.tick, durable);
    assert_eq!(report.mismatches, 0);
    assert_eq!(
        fs::metadata(path).unwrap().len(),
        bytes.len() as u64,
        "the damaged segment keeps its full length"
    );
    assert_same_files(&dir, &before, "nothing on disk changed");
    assert_eq!(report.damage.len(), 1, "{:?}", report.damage);
    assert_eq!(report.damage[0].path, *path);
    assert_eq!(report.damage[0].offset, hit.offset as u64);
    assert!(
        matches!(
            report.damage[0].why,
            DamageKind::Frame { read_on_at: Some(at), .. } if at == hit.end() as u64
        ),
        "the skipped bytes said: {}",
        report.damage[0]
    );
    assert_eq!(report.bytes_cut(), 0);

    // Recording goes on in a new segment, never after the damage.
    sim.start_recording().unwrap();
    for client in report.clients.clone() {
        sim.leave(client);
    }
    sim.join(7).unwrap();
    drive(&mut sim, 40);
    sim.finish_recording();
    assert_eq!(
        fs::read(path).unwrap(),
        bytes,
        "the damaged segment is kept as is"
    );
    let files = segments(&dir);
    assert_eq!(files.len(), 2, "{files:?}");
    assert!(files[1]
        .to_string_lossy()
        .ends_with(&format!("segment-{durable:020}.irec")));

    // And a later resume (another crash) reads past the damaged segment
    // into the new one.
    let (_, again) = resume(&dir).expect("resumes again");
    assert_eq!(again.tick, durable + 40);
    assert_eq!(again.mismatches, 0);
    assert_eq!(fs::read(path).unwrap(), bytes);
}

#[test]
fn issue_44_a_flipped_bit_in_a_segments_first_keyframe_resumes_from_its_newest() {
    let scratch = Scratch::new("first-of-many");
    let dir = scratch.recording();
    record(&dir, 600, 30, 64 * 1024 * 1024);
    let files = segments(&dir);
    assert_eq!(files.len(), 1);
    let mut bytes = fs::read(&files[0]).unwrap();
    let all = frames(&bytes);
    let first = *all.iter().find(|f| f.kind == KEYFRAME).unwrap();
    let newest = *keyframes_before(&bytes, bytes.len()).last().unwrap();
    assert!(newest >= 600, "every later keyframe intact: {newest}");
    bytes[first.offset + 5 + first.len / 2] ^= 0x01;
    fs::write(&files[0], &bytes).unwrap();
    let before = snapshot(&dir);

    let (_, report) = resume(&dir).expect("the later keyframes resume");
    assert_same_files(&dir, &before, "nothing on disk changed");
    assert_eq!(report.keyframe_tick, newest);
    assert_eq!(report.mismatches, 0);
    assert_eq!(report.damage.len(), 1, "{:?}", report.damage);
    assert_eq!(report.damage[0].offset, first.offset as u64);
    assert!(
        report.damage[0]
            .to_string()
            .contains(&format!("read on at byte {}", first.end())),
        "{}",
        report.damage[0]
    );
}

#[test]
fn issue_11_a_flipped_bit_in_every_keyframe_cuts_nothing_and_fails_typed() {
    let scratch = Scratch::new("every-keyframe");
    let dir = scratch.recording();
    record(&dir, 200, 30, 64 * 1024 * 1024);
    let files = segments(&dir);
    assert_eq!(files.len(), 1);
    let mut bytes = fs::read(&files[0]).unwrap();
    let keyframes: Vec<Frame> = frames(&bytes)
        .into_iter()
        .filter(|f| f.kind == KEYFRAME)
        .collect();
    assert!(keyframes.len() >= 2, "{keyframes:?}");
    for k in &keyframes {
        bytes[k.offset + 5 + k.len / 2] ^= 0x01;
    }
    fs::write(&files[0], &bytes).unwrap();
    let before = snapshot(&dir);

    let result = resume(&dir);
    assert_same_files(&dir, &before, "a failed resume changes no file");
    match result {
        Err(ResumeError::NoIntactKeyframe { damage, .. }) => {
            let offsets: Vec<u64> = damage.iter().map(|d| d.offset).collect();
            let want: Vec<u64> = keyframes.iter().map(|k| k.offset as u64).collect();
            assert_eq!(offsets, want, "each damaged keyframe said, and read past");
        }
        Err(e) => panic!("the wrong error: {e}"),
        Ok((_, report)) => panic!("resumed from damage: {report:?}"),
    }
}

#[test]
fn issue_11_damage_in_an_older_segment_leaves_the_newest_untouched() {
    let scratch = Scratch::new("older");
    let dir = scratch.recording();
    record(&dir, 600, 30, 6_000);
    let files = segments(&dir);
    assert!(files.len() >= 3, "{files:?}");
    let first = &files[0];
    let newest = files.last().unwrap();
    let mut bytes = fs::read(first).unwrap();
    let middle = *frames(&bytes)
        .iter()
        .find(|f| f.contains(bytes.len() / 2))
        .unwrap();
    bytes[middle.offset + 5 + middle.len / 2] ^= 0x40;
    fs::write(first, &bytes).unwrap();
    let pristine = snapshot(&dir);

    // Loading went on past the damage, from the next keyframe after it (in
    // the same segment, or the next), as a session of its own: nothing
    // re-simulates across the records lost in the damage.
    let plan = read_for_resume(&dir, DEFAULT_KEYFRAME_BUDGET).unwrap();
    let second = fs::read(&files[1]).unwrap();
    let second_start = frames(&second)[0].tick(&second);
    let next_keyframe = frames(&bytes)
        .iter()
        .filter(|f| f.kind == KEYFRAME && f.offset > middle.offset)
        .map(|f| f.tick(&bytes))
        .next()
        .unwrap_or(second_start);
    assert_eq!(plan.history().session_of(second_start), Some(next_keyframe));
    assert_eq!(plan.damage().len(), 1, "{:?}", plan.damage());
    drop(plan);

    // The newest segment intact: resume reads it, nothing changes.
    let newest_bytes = fs::read(newest).unwrap();
    let newest_keyframe = frames(&newest_bytes)
        .iter()
        .filter(|f| f.kind == KEYFRAME)
        .map(|f| f.tick(&newest_bytes))
        .max()
        .unwrap();
    let (_, report) = resume(&dir).expect("older damage does not stop a resume");
    assert_eq!(report.keyframe_tick, newest_keyframe);
    assert_eq!(report.tick, 600, "the last tick recorded");
    assert_same_files(&dir, &pristine, "nothing on disk changed");
    assert!(
        report
            .damage
            .iter()
            .any(|d| d.path == *first && d.offset == middle.offset as u64),
        "{:?}",
        report.damage
    );

    // The newest segment ending in a torn record as well: only that torn
    // record is cut, and kept aside; the damaged older segment is as it
    // was.
    let torn = &newest_bytes[frames(&newest_bytes).last().unwrap().offset..][..7];
    let mut with_torn = newest_bytes.clone();
    with_torn.extend_from_slice(torn);
    fs::write(newest, &with_torn).unwrap();
    let (_, report) = resume(&dir).expect("resumes");
    assert_eq!(report.bytes_cut(), 7);
    assert_eq!(
        fs::read(newest).unwrap(),
        newest_bytes,
        "only the torn record cut"
    );
    let aside = kept_aside(&dir);
    assert_eq!(aside.values().collect::<Vec<_>>(), vec![&torn.to_vec()]);
    assert_eq!(fs::read(first).unwrap(), bytes);
    for (name, content) in &pristine {
        if !newest.ends_with(name) {
            assert_eq!(&fs::read(dir.join(name)).unwrap(), content, "{name}");
        }
    }
}

#[test]
fn issue_11_a_torn_tail_is_cut_and_its_bytes_kept_aside() {
    let scratch = Scratch::new("torn");
    let dir = scratch.recording();
    record(&dir, 200, 30, 64 * 1024 * 1024);
    let path = segments(&dir).remove(0);
    let intact = fs::read(&path).unwrap();
    // A crash mid-append: the last keyframe written again, cut short in
    // its payload (its header says more bytes follow than the file has).
    let last = *frames(&intact)
        .iter()
        .rfind(|f| f.kind == KEYFRAME)
        .unwrap();
    let whole = &intact[last.offset..last.end()];
    let torn = whole[..whole.len() / 2].to_vec();
    let mut bytes = intact.clone();
    bytes.extend_from_slice(&torn);
    fs::write(&path, &bytes).unwrap();

    let (_, report) = resume(&dir).expect("a torn tail does not stop a resume");
    assert_eq!(report.bytes_cut(), torn.len() as u64);
    assert_eq!(
        fs::read(&path).unwrap(),
        intact,
        "cut exactly at the torn record"
    );
    let aside = kept_aside(&dir);
    let name = format!(
        "{}.torn-{}",
        path.file_name().unwrap().to_string_lossy(),
        intact.len()
    );
    assert_eq!(aside.keys().collect::<Vec<_>>(), vec![&name], "{aside:?}");
    assert_eq!(aside[&name], torn, "the bytes kept aside are the bytes cut");
    let cut = report.torn_tail.as_ref().expect("the cut is reported");
    assert_eq!(cut.kept_at, dir.join(&name));
    assert_eq!(cut.offset, intact.len() as u64);
    assert!(report.damage.is_empty(), "{:?}", report.damage);
}

#[test]
fn issue_11_a_length_flipped_mid_segment_is_damage_not_a_torn_tail() {
    // A flipped high bit in a record's length makes it run past the end of
    // the file, like a torn record, but intact records follow it: it is
    // damage, and nothing is cut.
    let scratch = Scratch::new("length");
    let dir = scratch.recording();
    record(&dir, 300, 30, 64 * 1024 * 1024);
    let path = segments(&dir).remove(0);
    let mut bytes = fs::read(&path).unwrap();
    let hit = frames(&bytes)
        .into_iter()
        .find(|f| f.offset >= bytes.len() / 3 && f.kind == TICK_HASH)
        .unwrap();
    bytes[hit.offset + 3] ^= 0x08; // + 512 KiB
    fs::write(&path, &bytes).unwrap();
    let before = snapshot(&dir);
    // Reading goes on at the record after it, to the end.
    let (_, report) = resume(&dir).expect("resumes past the damage");
    assert_eq!(report.tick, 300, "the last tick recorded");
    assert_same_files(&dir, &before, "nothing cut");
    assert_eq!(report.bytes_cut(), 0);
    assert_eq!(report.damage.len(), 1, "{:?}", report.damage);
}

#[test]
fn issue_11_a_keyframe_that_does_not_decode_is_damage_and_resume_uses_the_one_before() {
    let scratch = Scratch::new("undecodable");
    let good = scratch.recording();
    record(&good, 200, 30, 64 * 1024 * 1024);
    let path = segments(&good).remove(0);
    let name = path.file_name().unwrap().to_owned();
    let bytes = fs::read(&path).unwrap();
    let keyframes: Vec<Frame> = frames(&bytes)
        .into_iter()
        .filter(|f| f.kind == KEYFRAME)
        .collect();
    let (newest, previous) = (
        keyframes[keyframes.len() - 1],
        keyframes[keyframes.len() - 2],
    );
    let durable = last_hash_before(&bytes, bytes.len());
    let payload = newest.payload(&bytes);
    let (tick, state) = payload.split_at(8);

    // Two ways to hold a checksummed keyframe that does not decode: the
    // saved state cut short (it unpacks, its header reads, the rest does
    // not), and a packed state whose zstd frame is garbage.
    let mut short = unpack(state).unwrap().into_owned();
    short.truncate(short.len() - 3);
    let mut cut_state = tick.to_vec();
    cut_state.extend_from_slice(&pack(&short));
    let mut garbage = payload.to_vec();
    for b in &mut garbage[8 + 8 + 4..] {
        *b = b.wrapping_mul(31).wrapping_add(7);
    }

    for (what, damaged_payload) in [("cut-short", cut_state), ("garbage", garbage)] {
        let dir = scratch.0.join(what);
        fs::create_dir_all(&dir).unwrap();
        let damaged = replace_frame(&bytes, newest, &frame_bytes(KEYFRAME, &damaged_payload));
        fs::write(dir.join(&name), &damaged).unwrap();

        // inspect reports it as damage, with where it is.
        let out = admin(&["replay-file", "inspect", dir.to_str().unwrap(), "--json"]);
        assert_eq!(
            out.status.code(),
            Some(1),
            "{what}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(summary["damaged"], true, "{what}: {summary}");
        let damage = summary["damage"].as_array().unwrap();
        assert_eq!(damage.len(), 1, "{what}: {summary}");
        assert_eq!(
            damage[0]["offset"], newest.offset as u64,
            "{what}: {summary}"
        );
        let text = admin(&["replay-file", "inspect", dir.to_str().unwrap()]);
        let text = String::from_utf8_lossy(&text.stdout).into_owned();
        assert!(!text.contains("damage: none"), "{what}: {text}");
        assert!(text.contains("keyframe"), "{what}: {text}");

        // resume falls back to the keyframe before it.
        let before = snapshot(&dir);
        let (_, report) = resume(&dir).expect("resumes from the keyframe before");
        assert_eq!(report.keyframe_tick, previous.tick(&bytes), "{what}");
        assert_eq!(report.tick, durable, "{what}");
        assert_eq!(report.mismatches, 0, "{what}");
        assert!(
            report
                .damage
                .iter()
                .any(|d| d.offset == newest.offset as u64),
            "{what}: {:?}",
            report.damage
        );
        assert_same_files(&dir, &before, &format!("{what}: nothing on disk changed"));
    }
}

#[test]
fn issue_11_damage_at_the_start_of_the_newest_segment_resumes_from_the_segment_before() {
    // Every keyframe of the newest segment fails its checksum, the one
    // that starts it first: the resume comes from the segment before, and
    // the recording cannot go on in a new segment of that same first tick,
    // so it is moved aside whole (nothing in it changed) and a fresh one
    // starts.
    let scratch = Scratch::new("newest-start");
    let dir = scratch.recording();
    // 610 ticks: the last keyframe every 30 is at 600, and the one that
    // ends the recording at 610.
    record(&dir, 610, 30, 6_000);
    let files = segments(&dir);
    assert!(files.len() >= 3, "{files:?}");
    let newest = files.last().unwrap();
    let mut bytes = fs::read(newest).unwrap();
    let first = frames(&bytes)[0];
    assert_eq!(first.kind, KEYFRAME);
    let first_tick = first.tick(&bytes);
    for keyframe in frames(&bytes).iter().filter(|f| f.kind == KEYFRAME) {
        bytes[keyframe.offset + 5 + keyframe.len / 2] ^= 0x02;
    }
    fs::write(newest, &bytes).unwrap();
    let before = snapshot(&dir);

    let (mut sim, report) = resume(&dir).expect("resumes from the segment before");
    assert!(report.keyframe_tick < first_tick, "{report:?}");
    assert_eq!(report.mismatches, 0);
    assert!(report.newest_damaged.is_some());
    assert_same_files(&dir, &before, "nothing on disk changed");

    sim.start_recording().unwrap();
    let tick = sim.world().tick();
    for client in report.clients.clone() {
        sim.leave(client);
    }
    drive(&mut sim, 10);
    sim.finish_recording();
    let aside: Vec<PathBuf> = fs::read_dir(&scratch.0)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("recording.")
        })
        .collect();
    assert_eq!(aside.len(), 1, "{aside:?}");
    assert_same_files(&aside[0], &before, "the recording moved aside as it was");
    let (_, again) = resume(&dir).expect("the fresh recording resumes");
    assert_eq!(again.tick, tick + 10);
    assert!(again.damage.is_empty(), "{:?}", again.damage);
}
