//! Checkpoint files: one [`SimState`] written by `save` and read by `load`,
//! kept in one checkpoint directory (`--checkpoint-dir`, by default
//! `<data-dir>/checkpoints`) and found there by [`CheckpointName`], never
//! by path.
//!
//! Everything is opened relative to the directory, which is itself opened
//! without following a symbolic link (`O_DIRECTORY | O_NOFOLLOW`), and
//! every name in it is opened with `O_NOFOLLOW`: a link planted in the
//! directory, at a checkpoint's name or anywhere else, is refused, never
//! followed. Only regular files are read or replaced; a FIFO, a device, a
//! socket or a directory under a checkpoint's name is refused
//! ([`CheckpointError::NotRegular`]), and is looked at before it is
//! opened (the open itself is `O_NONBLOCK | O_NOCTTY`, so even one swapped
//! in between never blocks, and what was opened is checked again).
//!
//! Reads are bounded by [`MAX_CHECKPOINT_BYTES`], the largest checkpoint
//! this server can write: a larger file is refused by its size before it
//! is read, and the read itself stops one byte past the bound, so a file
//! that grows while it is read (or lies about its size) costs no more.
//!
//! A save is written to a new hidden file in the directory (created with
//! `O_CREAT | O_EXCL | O_NOFOLLOW`, so nothing already there is opened),
//! flushed to disk, and renamed into place, so a crash never leaves half a
//! checkpoint under its name. Without `overwrite` the rename refuses to
//! replace anything (`RENAME_NOREPLACE`, else a hard link, which refuses
//! just as atomically); with it, only a regular file is replaced. The
//! directory is created (mode 0700) on the first save; checkpoints are
//! mode 0600. A save interrupted by a crash can leave a
//! `.<name>.<pid>.<n>.partial` file in the directory: it is never loaded
//! (no checkpoint name starts with `.`) and may be deleted.
//!
//! The file system is touched only here, never on the tick thread: the
//! admin channel calls these functions from a blocking task and hands the
//! decoded state to the simulation.

use std::path::{Path, PathBuf};

pub use inertia_protocol::admin::CheckpointName;
use inertia_protocol::admin::{AdminErrorKind, AdminValidationError};

use super::state::{SimState, StateError};
use crate::record::MAX_RECORD_BYTES;

/// Largest checkpoint file read, bytes: the largest state the recording
/// holds ([`MAX_RECORD_BYTES`], which the state's own unpacking enforces)
/// and the 8-byte header of a packed one. [`CheckpointDir::write`] refuses
/// a state it could not read back, so every checkpoint this server writes
/// is within it; a larger file is not one.
pub const MAX_CHECKPOINT_BYTES: u64 = MAX_RECORD_BYTES as u64 + 8;

/// Why a checkpoint could not be written or read. Each says what the
/// operator can do about it.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// Not a checkpoint name (a path, say).
    #[error("{name:?} is not a checkpoint name: {source}")]
    BadName {
        /// What was given.
        name: String,
        /// Why it is not a name.
        source: AdminValidationError,
    },
    /// No checkpoint of that name.
    #[error("no checkpoint named {name} in {}", dir.display())]
    NotFound {
        /// The checkpoint directory.
        dir: PathBuf,
        /// The name.
        name: CheckpointName,
    },
    /// A save without `overwrite` found one of that name.
    #[error(
        "a checkpoint named {name} already exists in {}: save with --overwrite to replace it, \
         or choose another name",
        dir.display()
    )]
    Exists {
        /// The checkpoint directory.
        dir: PathBuf,
        /// The name.
        name: CheckpointName,
    },
    /// A symbolic link under the name (never followed).
    #[error(
        "{} is a symbolic link; checkpoint links are never followed: remove it, or choose \
         another name",
        dir.join(name.as_str()).display()
    )]
    Symlink {
        /// The checkpoint directory.
        dir: PathBuf,
        /// The name.
        name: CheckpointName,
    },
    /// Something other than a regular file under the name.
    #[error(
        "{} is a {kind}, not a regular file; checkpoints are regular files: remove it, or \
         choose another name",
        dir.join(name.as_str()).display()
    )]
    NotRegular {
        /// The checkpoint directory.
        dir: PathBuf,
        /// The name.
        name: CheckpointName,
        /// What it is (`FIFO`, `character device`, ...).
        kind: &'static str,
    },
    /// A file larger than [`MAX_CHECKPOINT_BYTES`], or a state too large
    /// to save as one.
    #[error(
        "{}: {len} bytes is larger than a checkpoint can be ({MAX_CHECKPOINT_BYTES} bytes); \
         it is not a checkpoint this server wrote",
        dir.join(name.as_str()).display()
    )]
    TooLarge {
        /// The checkpoint directory.
        dir: PathBuf,
        /// The name.
        name: CheckpointName,
        /// Its length (at least, for a file that grew), bytes.
        len: u64,
    },
    /// The checkpoint directory is not a directory one can use.
    #[error(
        "the checkpoint directory {} is {what}; give --checkpoint-dir a real directory",
        dir.display()
    )]
    Directory {
        /// The directory.
        dir: PathBuf,
        /// What it is instead (`a symbolic link`, `not a directory`).
        what: &'static str,
    },
    /// A save could not find a free temporary name in the directory.
    #[error(
        "cannot create a temporary file for {name} in {}: every name tried is taken; remove \
         the `.{name}.*.partial` files there",
        dir.display()
    )]
    NoTemporary {
        /// The checkpoint directory.
        dir: PathBuf,
        /// The name.
        name: CheckpointName,
    },
    /// The file system refused.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The bytes are not a saved state.
    #[error("{}: {source}", path.display())]
    State {
        /// The file.
        path: PathBuf,
        /// Why.
        source: StateError,
    },
    /// This platform cannot open files safely relative to a directory.
    #[error("checkpoints need a Unix system (directory-relative, no-follow file access)")]
    Unsupported,
}

impl CheckpointError {
    /// The admin error kind it is answered with.
    pub fn kind(&self) -> AdminErrorKind {
        match self {
            CheckpointError::NotFound { .. } => AdminErrorKind::NotFound,
            CheckpointError::Directory { .. }
            | CheckpointError::NoTemporary { .. }
            | CheckpointError::Io { .. } => AdminErrorKind::Io,
            CheckpointError::Unsupported => AdminErrorKind::Unsupported,
            CheckpointError::BadName { .. }
            | CheckpointError::Exists { .. }
            | CheckpointError::Symlink { .. }
            | CheckpointError::NotRegular { .. }
            | CheckpointError::TooLarge { .. }
            | CheckpointError::State { .. } => AdminErrorKind::Invalid,
        }
    }
}

/// The checkpoint directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CheckpointDir {
    path: PathBuf,
}

impl CheckpointDir {
    /// The directory at `path` (nothing is touched until a save or load).
    pub fn new(path: impl Into<PathBuf>) -> CheckpointDir {
        CheckpointDir { path: path.into() }
    }

    /// Where it is.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes `bytes` (an encoded [`SimState`]) as checkpoint `name`,
    /// packed with zstd ([`crate::record::compress`]), durably. Without
    /// `overwrite` a checkpoint already there is kept and the save refused
    /// ([`CheckpointError::Exists`]). Gives the bytes written.
    pub fn write(
        &self,
        name: &CheckpointName,
        bytes: &[u8],
        overwrite: bool,
    ) -> Result<u64, CheckpointError> {
        check_name(name)?;
        // What `load` could not read back is not written.
        if bytes.len() as u64 > u64::from(MAX_RECORD_BYTES) {
            return Err(CheckpointError::TooLarge {
                dir: self.path.clone(),
                name: name.clone(),
                len: bytes.len() as u64,
            });
        }
        let packed = crate::record::compress::pack(bytes);
        imp::write(self, name, &packed, overwrite)?;
        Ok(packed.len() as u64)
    }

    /// Reads (at most [`MAX_CHECKPOINT_BYTES`]) and decodes checkpoint
    /// `name`.
    pub fn read(&self, name: &CheckpointName) -> Result<SimState, CheckpointError> {
        check_name(name)?;
        let bytes = imp::read(self, name)?;
        SimState::decode(&bytes).map_err(|source| CheckpointError::State {
            path: self.path.join(name.as_str()),
            source,
        })
    }
}

/// Names are checked when a request arrives; again here, where they name
/// a file.
fn check_name(name: &CheckpointName) -> Result<(), CheckpointError> {
    name.check().map_err(|source| CheckpointError::BadName {
        name: name.as_str().to_string(),
        source,
    })
}

#[cfg(unix)]
mod imp {
    use std::io::{Read, Write};
    use std::os::fd::OwnedFd;
    use std::sync::atomic::{AtomicU64, Ordering};

    use rustix::fs::{AtFlags, FileType, Mode, OFlags, RenameFlags, Stat};
    use rustix::io::Errno;

    use super::{CheckpointDir, CheckpointError, CheckpointName, MAX_CHECKPOINT_BYTES};

    /// Temporary names tried by one save before it gives up.
    const TEMP_ATTEMPTS: u32 = 16;

    /// Numbers the temporary files of this process's saves.
    static NEXT_TEMP: AtomicU64 = AtomicU64::new(0);

    impl CheckpointDir {
        fn io(&self, name: Option<&str>, e: Errno) -> CheckpointError {
            CheckpointError::Io {
                path: match name {
                    Some(n) => self.path.join(n),
                    None => self.path.clone(),
                },
                source: e.into(),
            }
        }

        /// Opens the directory without following a link; creates it
        /// (mode 0700, and any missing parents) first when `create`. A
        /// missing one gives `Ok(None)`.
        fn open(&self, create: bool) -> Result<Option<OwnedFd>, CheckpointError> {
            let flags = OFlags::RDONLY | OFlags::DIRECTORY | OFlags::NOFOLLOW | OFlags::CLOEXEC;
            let open = || rustix::fs::openat(rustix::fs::CWD, &self.path, flags, Mode::empty());
            let refused = |e: Errno| match e {
                Errno::LOOP => CheckpointError::Directory {
                    dir: self.path.clone(),
                    what: "a symbolic link",
                },
                Errno::NOTDIR => CheckpointError::Directory {
                    dir: self.path.clone(),
                    what: "not a directory",
                },
                e => self.io(None, e),
            };
            match open() {
                Ok(fd) => Ok(Some(fd)),
                Err(Errno::NOENT) if create => {
                    use std::os::unix::fs::DirBuilderExt;
                    std::fs::DirBuilder::new()
                        .recursive(true)
                        .mode(0o700)
                        .create(&self.path)
                        .map_err(|source| CheckpointError::Io {
                            path: self.path.clone(),
                            source,
                        })?;
                    open().map(Some).map_err(refused)
                }
                Err(Errno::NOENT) => Ok(None),
                Err(e) => Err(refused(e)),
            }
        }

        /// The directory entry `name`, not followed; `None` if there is
        /// none.
        fn look(
            &self,
            dir: &OwnedFd,
            name: &CheckpointName,
        ) -> Result<Option<Stat>, CheckpointError> {
            match rustix::fs::statat(dir, name.as_str(), AtFlags::SYMLINK_NOFOLLOW) {
                Ok(st) => Ok(Some(st)),
                Err(Errno::NOENT) => Ok(None),
                Err(e) => Err(self.io(Some(name.as_str()), e)),
            }
        }

        /// Refuses what is not a regular file of a checkpoint's size; its
        /// length.
        fn checkpoint_file(
            &self,
            name: &CheckpointName,
            st: &Stat,
        ) -> Result<u64, CheckpointError> {
            self.regular(name, st)?;
            let len = u64::try_from(st.st_size).unwrap_or(0);
            if len > MAX_CHECKPOINT_BYTES {
                return Err(CheckpointError::TooLarge {
                    dir: self.path.clone(),
                    name: name.clone(),
                    len,
                });
            }
            Ok(len)
        }

        /// Refuses what is not a regular file.
        fn regular(&self, name: &CheckpointName, st: &Stat) -> Result<(), CheckpointError> {
            let kind = match FileType::from_raw_mode(st.st_mode) {
                FileType::RegularFile => return Ok(()),
                FileType::Symlink => {
                    return Err(CheckpointError::Symlink {
                        dir: self.path.clone(),
                        name: name.clone(),
                    })
                }
                FileType::Fifo => "FIFO",
                FileType::CharacterDevice => "character device",
                FileType::BlockDevice => "block device",
                FileType::Socket => "socket",
                FileType::Directory => "directory",
                FileType::Unknown => "file of an unknown kind",
            };
            Err(CheckpointError::NotRegular {
                dir: self.path.clone(),
                name: name.clone(),
                kind,
            })
        }
    }

    pub(super) fn read(
        dir: &CheckpointDir,
        name: &CheckpointName,
    ) -> Result<Vec<u8>, CheckpointError> {
        let not_found = || CheckpointError::NotFound {
            dir: dir.path.clone(),
            name: name.clone(),
        };
        let fd = dir.open(false)?.ok_or_else(not_found)?;
        // Looked at first, so a device or FIFO is never opened.
        let st = dir.look(&fd, name)?.ok_or_else(not_found)?;
        dir.checkpoint_file(name, &st)?;
        let flags =
            OFlags::RDONLY | OFlags::NOFOLLOW | OFlags::NONBLOCK | OFlags::NOCTTY | OFlags::CLOEXEC;
        let file =
            rustix::fs::openat(&fd, name.as_str(), flags, Mode::empty()).map_err(|e| match e {
                Errno::NOENT => not_found(),
                Errno::LOOP => CheckpointError::Symlink {
                    dir: dir.path.clone(),
                    name: name.clone(),
                },
                e => dir.io(Some(name.as_str()), e),
            })?;
        // What was opened is what counts (the name may have changed since
        // it was looked at).
        let st = rustix::fs::fstat(&file).map_err(|e| dir.io(Some(name.as_str()), e))?;
        let len = dir.checkpoint_file(name, &st)?;
        let mut bytes = Vec::with_capacity(len as usize);
        std::fs::File::from(file)
            .take(MAX_CHECKPOINT_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(|source| CheckpointError::Io {
                path: dir.path.join(name.as_str()),
                source,
            })?;
        if bytes.len() as u64 > MAX_CHECKPOINT_BYTES {
            return Err(CheckpointError::TooLarge {
                dir: dir.path.clone(),
                name: name.clone(),
                len: bytes.len() as u64,
            });
        }
        Ok(bytes)
    }

    /// A temporary file this save created, removed unless it was renamed
    /// into place.
    struct Temp<'a> {
        dir: &'a OwnedFd,
        name: String,
        placed: bool,
    }

    impl Drop for Temp<'_> {
        fn drop(&mut self) {
            if !self.placed {
                let _ = rustix::fs::unlinkat(self.dir, self.name.as_str(), AtFlags::empty());
            }
        }
    }

    pub(super) fn write(
        dir: &CheckpointDir,
        name: &CheckpointName,
        bytes: &[u8],
        overwrite: bool,
    ) -> Result<(), CheckpointError> {
        let fd = dir.open(true)?.ok_or_else(|| dir.io(None, Errno::NOENT))?;
        // Refused early, before anything is written: a save over
        // something that is not a regular checkpoint (even with
        // `overwrite`), or over one without it. The rename below decides
        // for the name as it is then; if it changes in between, a rename
        // never follows a link, so only the directory entry is affected.
        if let Some(st) = dir.look(&fd, name)? {
            dir.regular(name, &st)?;
            if !overwrite {
                return Err(exists(dir, name));
            }
        }

        let (mut file, mut temp) = create_temp(dir, &fd, name)?;
        let temp_path = dir.path.join(&temp.name);
        let tmp_io = |source: std::io::Error| CheckpointError::Io {
            path: temp_path.clone(),
            source,
        };
        file.write_all(bytes).map_err(tmp_io)?;
        file.sync_all().map_err(tmp_io)?;
        drop(file);

        if overwrite {
            rustix::fs::renameat(&fd, temp.name.as_str(), &fd, name.as_str())
                .map_err(|e| dir.io(Some(name.as_str()), e))?;
            temp.placed = true;
        } else {
            match rustix::fs::renameat_with(
                &fd,
                temp.name.as_str(),
                &fd,
                name.as_str(),
                RenameFlags::NOREPLACE,
            ) {
                Ok(()) => temp.placed = true,
                Err(Errno::EXIST) => return Err(exists(dir, name)),
                // The file system cannot rename without replacing: a hard
                // link refuses an existing name just as atomically (the
                // temporary name is removed when `temp` drops).
                Err(Errno::INVAL | Errno::NOSYS | Errno::OPNOTSUPP) => {
                    match rustix::fs::linkat(
                        &fd,
                        temp.name.as_str(),
                        &fd,
                        name.as_str(),
                        AtFlags::empty(),
                    ) {
                        Ok(()) => {}
                        Err(Errno::EXIST) => return Err(exists(dir, name)),
                        Err(e) => return Err(dir.io(Some(name.as_str()), e)),
                    }
                }
                Err(e) => return Err(dir.io(Some(name.as_str()), e)),
            }
        }
        drop(temp);
        // The new name on disk too.
        rustix::fs::fsync(&fd).map_err(|e| dir.io(None, e))?;
        Ok(())
    }

    fn exists(dir: &CheckpointDir, name: &CheckpointName) -> CheckpointError {
        CheckpointError::Exists {
            dir: dir.path.clone(),
            name: name.clone(),
        }
    }

    /// Creates a new temporary file for `name` in the directory: hidden
    /// (no checkpoint name starts with `.`), unique to this process and
    /// save, and never one already there (`O_EXCL`: not a file, not a
    /// link planted at the name).
    fn create_temp<'a>(
        dir: &CheckpointDir,
        fd: &'a OwnedFd,
        name: &CheckpointName,
    ) -> Result<(std::fs::File, Temp<'a>), CheckpointError> {
        let flags = OFlags::WRONLY
            | OFlags::CREATE
            | OFlags::EXCL
            | OFlags::NOFOLLOW
            | OFlags::NOCTTY
            | OFlags::CLOEXEC;
        for _ in 0..TEMP_ATTEMPTS {
            let n = NEXT_TEMP.fetch_add(1, Ordering::Relaxed);
            let temp = format!(".{name}.{}.{n}.partial", std::process::id());
            match rustix::fs::openat(fd, temp.as_str(), flags, Mode::RUSR | Mode::WUSR) {
                Ok(file) => {
                    return Ok((
                        std::fs::File::from(file),
                        Temp {
                            dir: fd,
                            name: temp,
                            placed: false,
                        },
                    ))
                }
                Err(Errno::EXIST) => continue,
                Err(e) => return Err(dir.io(Some(temp.as_str()), e)),
            }
        }
        Err(CheckpointError::NoTemporary {
            dir: dir.path.clone(),
            name: name.clone(),
        })
    }
}

#[cfg(not(unix))]
mod imp {
    use super::{CheckpointDir, CheckpointError, CheckpointName};

    pub(super) fn read(_: &CheckpointDir, _: &CheckpointName) -> Result<Vec<u8>, CheckpointError> {
        Err(CheckpointError::Unsupported)
    }

    pub(super) fn write(
        _: &CheckpointDir,
        _: &CheckpointName,
        _: &[u8],
        _: bool,
    ) -> Result<(), CheckpointError> {
        Err(CheckpointError::Unsupported)
    }
}
