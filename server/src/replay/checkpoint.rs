//! Checkpoint files: one [`SimState`] written by `save` and read by `load`.
//! A file is written beside its final name and renamed into place, so a
//! crash never leaves half a checkpoint under the name asked for.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::state::{SimState, StateError};

/// Largest checkpoint file read, bytes (1 GiB).
pub const MAX_CHECKPOINT_BYTES: u64 = 1 << 30;

/// Why a checkpoint could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// The file system refused.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file is larger than [`MAX_CHECKPOINT_BYTES`].
    #[error("{}: {len} bytes is larger than a checkpoint may be ({MAX_CHECKPOINT_BYTES})", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its length.
        len: u64,
    },
    /// The bytes are not a saved state.
    #[error("{}: {source}", path.display())]
    State {
        /// The file.
        path: PathBuf,
        /// Why.
        source: StateError,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> CheckpointError + '_ {
    move |source| CheckpointError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes `bytes` (an encoded [`SimState`]) to `path`, packed with zstd
/// ([`crate::record::compress`]), durably.
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), CheckpointError> {
    let packed = crate::record::compress::pack(bytes);
    let bytes = packed.as_slice();
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".partial");
    let tmp = PathBuf::from(tmp);
    let mut f = std::fs::File::create(&tmp).map_err(io(&tmp))?;
    f.write_all(bytes).map_err(io(&tmp))?;
    f.sync_all().map_err(io(&tmp))?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(io(path))?;
    Ok(())
}

/// Reads and decodes the checkpoint at `path`.
pub fn read(path: &Path) -> Result<SimState, CheckpointError> {
    let len = std::fs::metadata(path).map_err(io(path))?.len();
    if len > MAX_CHECKPOINT_BYTES {
        return Err(CheckpointError::TooLarge {
            path: path.to_path_buf(),
            len,
        });
    }
    let bytes = std::fs::read(path).map_err(io(path))?;
    SimState::decode(&bytes).map_err(|source| CheckpointError::State {
        path: path.to_path_buf(),
        source,
    })
}
