//! A checkpoint file as `load` finds it in the checkpoint directory: the
//! bounded read, the unpacking and the decoding never panic, and what
//! reads restores (or is refused) and steps.
#![no_main]

use std::sync::OnceLock;

use inertia_server::replay::checkpoint::{CheckpointDir, CheckpointName};
use libfuzzer_sys::fuzz_target;

fn dir() -> &'static CheckpointDir {
    static DIR: OnceLock<CheckpointDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let path =
            std::env::temp_dir().join(format!("inertia-fuzz-checkpoints-{}", std::process::id()));
        std::fs::create_dir_all(&path).expect("a temporary checkpoint directory");
        CheckpointDir::new(path)
    })
}

fuzz_target!(|data: &[u8]| {
    let dir = dir();
    let name = CheckpointName::new("fuzz").expect("a valid name");
    std::fs::write(dir.path().join("fuzz"), data).expect("writing the checkpoint file");
    if let Ok(state) = dir.read(&name) {
        inertia_fuzz::drive_state(&state.encode());
    }
});
