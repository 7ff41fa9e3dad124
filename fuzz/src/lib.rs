//! What the fuzz targets share: driving a decoded scene, world or saved
//! state the way the server goes on to use it, so that a decoder which
//! accepts something the engine cannot run is found too.

use std::cell::RefCell;

use inertia_physics::{World, WorldConfig};
use inertia_protocol::control::{
    encode_frame, ControlError, ControlMessage, FrameDecoder, MAX_DECODER_BUFFER,
};
use inertia_server::replay::SimState;
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::{SimConfig, Simulation};

/// Ticks stepped after a successful decode.
const TICKS: usize = 2;
/// Most rigid bodies a fuzzed world may hold ([`WorldConfig::max_bodies`]):
/// a scene or a state with more is refused as the server refuses one past
/// `--max-bodies`, at the body past the limit, so the fuzzer makes many
/// short runs rather than a few long ones and reaches that refusal too.
const MAX_BODIES: usize = 200;
/// Tick length, s.
const DT: f64 = 1.0 / 60.0;

/// One thread (the fuzzer runs many processes, not wide steps), and at
/// most [`MAX_BODIES`] bodies.
fn config() -> WorldConfig {
    WorldConfig {
        threads: 1,
        max_bodies: MAX_BODIES,
        ..WorldConfig::default()
    }
}

/// Reads `data` as a scene file in `format` as the server does at start:
/// a scene that parses is built once, which checks it (or refuses it past
/// [`MAX_BODIES`]), and a built scene is stepped.
pub fn drive_scene(data: &[u8], format: SceneFormat) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = Scene::read(text, format) else {
        return;
    };
    let Ok(mut built) = scene.build_with(config()) else {
        return;
    };
    assert!(built.world.bodies().count() <= MAX_BODIES);
    for _ in 0..TICKS {
        let _ = built.world.step(DT);
    }
}

/// Restores `data` as a world's saved bytes into an empty world: a refused
/// restore leaves the world as it was; a restored world steps.
pub fn drive_world(data: &[u8]) {
    thread_local! {
        /// One world for every run, emptied before each: making a world
        /// costs more than most inputs take to refuse.
        static WORLD: RefCell<(World, Vec<u8>)> = RefCell::new({
            let world = World::new(config()).expect("an empty world");
            let empty = world.save();
            (world, empty)
        });
    }
    WORLD.with_borrow_mut(|(world, empty)| {
        world.restore(empty).expect("the empty world restores");
        let before = world.state_hash();
        // Past the checksum, or every mutation would stop there.
        let mut sealed = data.to_vec();
        inertia_physics::saved_state::reseal(&mut sealed);
        if world.restore(&sealed).is_err() {
            assert_eq!(
                world.state_hash(),
                before,
                "a refused restore changed the world"
            );
            return;
        }
        for _ in 0..TICKS {
            let _ = world.step(DT);
        }
    });
}

/// Decodes `data` as a saved simulation state, checks that `peek` agrees
/// and that it encodes to bytes that decode the same, then restores it
/// into a running simulation (the sandbox rules) and ticks it.
pub fn drive_state(data: &[u8]) {
    let peeked = SimState::peek(data);
    let Ok(mut state) = SimState::decode(data) else {
        return;
    };
    assert_eq!(peeked.ok(), Some((state.tick, state.applied)));
    let encoded = state.encode();
    let again = SimState::decode(&encoded).expect("an encoded state decodes");
    assert_eq!(again.encode(), encoded);
    // Past the world's checksum, or every mutation of it would stop there.
    inertia_physics::saved_state::reseal(&mut state.world);

    thread_local! {
        /// One simulation for every run, put back to its first state
        /// before each.
        static SIM: RefCell<(Simulation, SimState)> = RefCell::new({
            let empty = Scene::parse("(name: \"fuzz\")", SceneFormat::Ron)
                .and_then(|scene| scene.build_with(config()))
                .expect("an empty scene");
            let sim = Simulation::new(
                empty,
                Box::new(SandboxRules::default()),
                SimConfig::default(),
            );
            let first = sim.capture(0);
            (sim, first)
        });
    }
    SIM.with_borrow_mut(|(sim, first)| {
        sim.restore(first).expect("the first state restores");
        if sim.restore(&state).is_ok() {
            for _ in 0..TICKS {
                sim.tick();
            }
        }
    });
}

/// Bytes of a segment's header (magic and version).
const SEGMENT_HEADER_BYTES: usize = 8;

/// Rewrites the CRC-32 of every whole frame in a segment's bytes so that
/// it matches the frame (kind, length and payload), for the fuzzer to
/// reach the record decoders behind the checksums. Stops at the first
/// frame whose length runs past the end.
pub fn reseal_frames(bytes: &mut [u8]) {
    let mut at = SEGMENT_HEADER_BYTES;
    while let Some(head) = bytes.get(at..at + 5) {
        let len = u32::from_le_bytes([head[1], head[2], head[3], head[4]]) as usize;
        let Some(crc_at) = (at + 5).checked_add(len) else {
            return;
        };
        if crc_at + 4 > bytes.len() {
            return;
        }
        let crc = inertia_server::record::crc32::crc32(&bytes[at..crc_at]);
        bytes[crc_at..crc_at + 4].copy_from_slice(&crc.to_le_bytes());
        at = crc_at + 4;
    }
}

/// Feeds a stream of framed control messages of type `T` to a
/// [`FrameDecoder`] in pieces of `chunk` bytes: the decoder never holds
/// more than its bound, and everything it yields has passed validation
/// (so it encodes again).
pub fn drive_frames<T: ControlMessage>(stream: &[u8], chunk: usize) {
    let mut decoder = FrameDecoder::new();
    for piece in stream.chunks(chunk.max(1)) {
        if decoder.push(piece).is_err() {
            return;
        }
        assert!(decoder.buffered() <= MAX_DECODER_BUFFER);
        loop {
            match decoder.next::<T>() {
                None => break,
                Some(Ok(msg)) => {
                    encode_frame(&msg).expect("a decoded message encodes");
                }
                Some(Err(ControlError::FrameTooLarge { .. })) => return,
                Some(Err(_)) => {}
            }
        }
    }
}
