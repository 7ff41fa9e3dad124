//! The physics world's saved bytes, the part of every keyframe and
//! checkpoint that is largest and most structured: restoring never panics,
//! a refused restore leaves the world as it was, and a restored world
//! steps without panicking.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| inertia_fuzz::drive_world(data));
