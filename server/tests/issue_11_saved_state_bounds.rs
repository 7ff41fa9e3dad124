//! A saved simulation state (keyframe or checkpoint) whose tick is past
//! what a world reaches is refused as malformed, as the world's own saved
//! tick is (found by the `fuzz_world_state` target, issue 11): the clock
//! and the recording count from it.

use inertia_physics::limits::MAX_TICK;
use inertia_server::replay::{SimState, StateError};
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::{SimConfig, Simulation};

#[test]
fn issue_11_saved_state_tick_past_the_last_is_refused() {
    let built = Scene::parse("(name: \"empty\")", SceneFormat::Ron)
        .and_then(|s| s.build())
        .expect("an empty scene");
    let sim = Simulation::new(
        built,
        Box::new(SandboxRules::default()),
        SimConfig::default(),
    );
    let mut state = sim.capture(0);
    state.tick = u64::MAX;
    match SimState::decode(&state.encode()) {
        Err(StateError::Malformed(why)) => assert!(why.contains("tick"), "{why}"),
        other => panic!("tick 2^64 - 1: {other:?}"),
    }
    state.tick = MAX_TICK;
    SimState::decode(&state.encode()).expect("the last tick decodes");
}
