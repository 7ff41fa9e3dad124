//! A saved simulation state (a keyframe's payload, or a checkpoint's
//! contents): decoding never panics, `peek` agrees with it, and a state
//! that decodes restores into a world (or is refused) that then steps.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| inertia_fuzz::drive_state(data));
