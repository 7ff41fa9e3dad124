//! A scene file in JSON, as an operator or a studio's pipeline hands it to
//! `--scene`: parsing and checking never panic, and a scene that checks
//! builds (or is refused with an error) and steps.
#![no_main]

use inertia_fuzz::drive_scene;
use inertia_server::scene::SceneFormat;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| drive_scene(data, SceneFormat::Json));
