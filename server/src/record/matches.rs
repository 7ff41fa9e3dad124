//! The recordings of finished matches, kept in `<data-dir>/matches/<name>/`
//! and read back through the admin channel (`inertia-admin matches`,
//! `inertia-admin fetch-recording`).
//!
//! When a match ends, its recording directory (`<data-dir>/recording`,
//! ended with a keyframe) is renamed to `matches/match-<unix seconds>`.
//! Reading follows no symbolic link: the matches directory and each
//! match's directory are opened `O_DIRECTORY | O_NOFOLLOW`, only regular
//! files whose names are plain file names are listed and read, and a read
//! is at most [`MAX_RECORDING_PART`] bytes. Names come in as
//! [`MatchName`]s, never paths.

use std::io;
use std::path::{Path, PathBuf};

use inertia_protocol::admin::{KeptMatch, MatchName, MAX_MATCHES_LISTED, MAX_RECORDING_PART};

/// Why a kept recording could not be read.
#[derive(Debug, thiserror::Error)]
pub enum MatchesError {
    /// No match of that name, or no file of that index in it.
    #[error("no {0}")]
    NotFound(String),
    /// The file system failed, or held something other than it should (a
    /// link, a device) where a match or its files should be.
    #[error("{what}: {source}")]
    Io {
        what: String,
        #[source]
        source: io::Error,
    },
}

/// One part of a kept recording's file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordingPart {
    /// Files in the recording.
    pub files: u32,
    /// This file's name.
    pub file_name: String,
    /// Its length, bytes.
    pub file_len: u64,
    /// Where `data` starts.
    pub offset: u64,
    /// At most [`MAX_RECORDING_PART`] bytes.
    pub data: Vec<u8>,
}

/// `rename`'s error across file systems (EXDEV on Linux and the BSDs).
const EXDEV: i32 = 18;

/// Copies the regular files of `from` into the new directory `to` (which
/// must not exist: [`io::ErrorKind::AlreadyExists`] otherwise), each
/// flushed to disk.
fn copy_recording(from: &Path, to: &Path) -> io::Result<()> {
    std::fs::create_dir(to)?;
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        if entry.file_type()?.is_file() {
            std::fs::copy(entry.path(), to.join(entry.file_name()))?;
            std::fs::File::open(to.join(entry.file_name()))?.sync_all()?;
        }
    }
    Ok(())
}

/// The kept matches' directory: `<data-dir>/matches`, or `--matches-dir`.
#[derive(Debug, Clone)]
pub struct MatchesDir {
    path: PathBuf,
}

impl MatchesDir {
    /// The matches directory at `path` (made by the first [`Self::keep`]).
    pub fn new(path: impl Into<PathBuf>) -> MatchesDir {
        MatchesDir { path: path.into() }
    }

    /// Where it is.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Moves the finished recording at `recording` in, named after
    /// `now_unix` (a suffix when another match took the name); `None` when
    /// there is no recording to keep. Across file systems it is copied,
    /// then removed. Blocking.
    pub fn keep(&self, recording: &Path, now_unix: u64) -> io::Result<Option<MatchName>> {
        if !std::fs::symlink_metadata(recording).is_ok_and(|m| m.is_dir()) {
            return Ok(None);
        }
        std::fs::create_dir_all(&self.path)?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&self.path, std::fs::Permissions::from_mode(0o700))?;
        }
        for n in 0..100u32 {
            let text = match n {
                0 => format!("match-{now_unix}"),
                n => format!("match-{now_unix}-{n}"),
            };
            let Ok(name) = MatchName::new(text) else {
                break;
            };
            let to = self.path.join(name.as_str());
            if std::fs::symlink_metadata(&to).is_ok() {
                continue;
            }
            match std::fs::rename(recording, &to) {
                Ok(()) => return Ok(Some(name)),
                // Another file system (a volume shared by a fleet): copied.
                Err(e) if e.raw_os_error() == Some(EXDEV) => match copy_recording(recording, &to) {
                    Ok(()) => {
                        std::fs::remove_dir_all(recording)?;
                        return Ok(Some(name));
                    }
                    // Another server took the name meanwhile.
                    Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
                    Err(e) => return Err(e),
                },
                Err(e) => return Err(e),
            }
        }
        Err(io::Error::new(
            io::ErrorKind::AlreadyExists,
            "no free match name for this second",
        ))
    }

    /// The kept matches, by name, at most the newest
    /// [`MAX_MATCHES_LISTED`]. Blocking.
    pub fn list(&self) -> Result<Vec<KeptMatch>, MatchesError> {
        let mut names: Vec<MatchName> = match imp::entries(&self.path, true) {
            Ok(names) => names,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
            Err(source) => return Err(self.io("the matches directory", source)),
        }
        .into_iter()
        .filter_map(|n| MatchName::new(n).ok())
        .collect();
        names.sort_by(|a, b| a.as_str().cmp(b.as_str()));
        let skip = names.len().saturating_sub(MAX_MATCHES_LISTED);
        names
            .into_iter()
            .skip(skip)
            .map(|name| {
                let files = self.files(&name)?;
                Ok(KeptMatch {
                    files: files.len() as u32,
                    bytes: files.iter().map(|(_, len)| len).sum(),
                    name,
                })
            })
            .collect()
    }

    /// Up to [`MAX_RECORDING_PART`] bytes of file `file` of match `name`
    /// from `offset` (none at or past its end). Blocking.
    pub fn read(
        &self,
        name: &MatchName,
        file: u32,
        offset: u64,
    ) -> Result<RecordingPart, MatchesError> {
        name.check()
            .map_err(|e| MatchesError::NotFound(format!("match {name:?}: {e}")))?;
        let files = self.files(name)?;
        let (file_name, _) = files
            .get(file as usize)
            .ok_or_else(|| MatchesError::NotFound(format!("file {file} in match {name}")))?;
        let (file_len, data) = imp::read(
            &self.path,
            name.as_str(),
            file_name,
            offset,
            MAX_RECORDING_PART,
        )
        .map_err(|source| self.io(&format!("{name}/{file_name}"), source))?;
        Ok(RecordingPart {
            files: files.len() as u32,
            file_name: file_name.clone(),
            file_len,
            offset,
            data,
        })
    }

    /// The regular files of match `name`, by name, with their lengths.
    fn files(&self, name: &MatchName) -> Result<Vec<(String, u64)>, MatchesError> {
        let names = imp::entries(&self.path.join(name.as_str()), false).map_err(|source| {
            if source.kind() == io::ErrorKind::NotFound {
                MatchesError::NotFound(format!("match {name}"))
            } else {
                self.io(&format!("match {name}"), source)
            }
        })?;
        let mut files: Vec<(String, u64)> = names
            .into_iter()
            .filter(|n| MatchName::new(n.as_str()).is_ok())
            .filter_map(|n| {
                let len = imp::regular_len(&self.path.join(name.as_str()).join(&n))?;
                Some((n, len))
            })
            .collect();
        files.sort();
        Ok(files)
    }

    fn io(&self, what: &str, source: io::Error) -> MatchesError {
        MatchesError::Io {
            what: format!("{} ({what})", self.path.display()),
            source,
        }
    }
}

/// The file system, following no link.
mod imp {
    use std::io::{self, Read, Seek, SeekFrom};
    use std::path::Path;

    /// Names in directory `dir` (itself no link) that are directories
    /// (`dirs`) or regular files (not), none of them links.
    pub(super) fn entries(dir: &Path, dirs: bool) -> io::Result<Vec<String>> {
        let meta = std::fs::symlink_metadata(dir)?;
        if !meta.is_dir() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "not a directory",
            ));
        }
        let mut out = Vec::new();
        for entry in std::fs::read_dir(dir)? {
            let entry = entry?;
            let kind = entry.file_type()?;
            let wanted = if dirs { kind.is_dir() } else { kind.is_file() };
            if wanted && !kind.is_symlink() {
                if let Ok(name) = entry.file_name().into_string() {
                    out.push(name);
                }
            }
        }
        Ok(out)
    }

    /// The length of `path` if it is a regular file (not a link).
    pub(super) fn regular_len(path: &Path) -> Option<u64> {
        let meta = std::fs::symlink_metadata(path).ok()?;
        meta.is_file().then_some(meta.len())
    }

    /// Up to `max` bytes of `dir/name/file` from `offset`, and the file's
    /// length; the match directory and the file are opened without
    /// following a link (a link swapped in after the listing is refused).
    pub(super) fn read(
        dir: &Path,
        name: &str,
        file: &str,
        offset: u64,
        max: usize,
    ) -> io::Result<(u64, Vec<u8>)> {
        let mut f = open_no_follow(&dir.join(name), file)?;
        let meta = f.metadata()?;
        if !meta.is_file() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "not a regular file",
            ));
        }
        let len = meta.len();
        let want = len.saturating_sub(offset).min(max as u64) as usize;
        let mut data = vec![0u8; want];
        if want > 0 {
            f.seek(SeekFrom::Start(offset))?;
            f.read_exact(&mut data)?;
        }
        Ok((len, data))
    }

    #[cfg(unix)]
    fn open_no_follow(dir: &Path, file: &str) -> io::Result<std::fs::File> {
        use rustix::fs::{openat, Mode, OFlags, CWD};
        let dir_flags = OFlags::RDONLY | OFlags::DIRECTORY | OFlags::NOFOLLOW | OFlags::CLOEXEC;
        let dir = openat(CWD, dir, dir_flags, Mode::empty())?;
        let file_flags =
            OFlags::RDONLY | OFlags::NOFOLLOW | OFlags::NONBLOCK | OFlags::NOCTTY | OFlags::CLOEXEC;
        Ok(std::fs::File::from(openat(
            &dir,
            file,
            file_flags,
            Mode::empty(),
        )?))
    }

    #[cfg(not(unix))]
    fn open_no_follow(dir: &Path, file: &str) -> io::Result<std::fs::File> {
        let path = dir.join(file);
        if std::fs::symlink_metadata(&path)?.file_type().is_symlink() {
            return Err(io::Error::new(io::ErrorKind::InvalidInput, "a link"));
        }
        std::fs::File::open(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(what: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("inertia-matches-{what}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_kept_recording_is_listed_and_read_back_in_parts() {
        let dir = scratch("keep");
        let recording = dir.join("recording");
        std::fs::create_dir_all(&recording).unwrap();
        let big: Vec<u8> = (0..(MAX_RECORDING_PART * 2 + 5)).map(|i| i as u8).collect();
        std::fs::write(recording.join("seg-0001"), &big).unwrap();
        std::fs::write(recording.join("seg-0000"), b"first").unwrap();
        let matches = MatchesDir::new(dir.join("matches"));
        assert!(matches.list().unwrap().is_empty(), "none before any");
        let name = matches.keep(&recording, 1_800_000_000).unwrap().unwrap();
        assert_eq!(name.as_str(), "match-1800000000");
        assert!(!recording.exists());
        // Nothing to keep the second time; the same second gets a suffix.
        assert_eq!(matches.keep(&recording, 1_800_000_000).unwrap(), None);
        std::fs::create_dir_all(&recording).unwrap();
        let second = matches.keep(&recording, 1_800_000_000).unwrap().unwrap();
        assert_eq!(second.as_str(), "match-1800000000-1");

        let listed = matches.list().unwrap();
        assert_eq!(listed.len(), 2);
        assert_eq!(
            (listed[0].files, listed[0].bytes),
            (2, big.len() as u64 + 5)
        );
        let first = matches.read(&name, 0, 0).unwrap();
        assert_eq!(
            (first.files, first.file_name.as_str(), first.data.as_slice()),
            (2, "seg-0000", &b"first"[..])
        );
        let mut back = Vec::new();
        loop {
            let part = matches.read(&name, 1, back.len() as u64).unwrap();
            if part.data.is_empty() {
                break;
            }
            assert!(part.data.len() <= MAX_RECORDING_PART);
            back.extend_from_slice(&part.data);
        }
        assert_eq!(back, big);
        assert!(matches!(
            matches.read(&name, 2, 0),
            Err(MatchesError::NotFound(_))
        ));
        let absent = MatchName::new("match-1").unwrap();
        assert!(matches!(
            matches.read(&absent, 0, 0),
            Err(MatchesError::NotFound(_))
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_recording_copied_across_file_systems_is_whole_and_never_overwrites() {
        let dir = scratch("copy");
        let from = dir.join("recording");
        std::fs::create_dir_all(&from).unwrap();
        std::fs::write(from.join("seg-0000"), b"segment").unwrap();
        copy_recording(&from, &dir.join("match-1")).unwrap();
        assert_eq!(
            std::fs::read(dir.join("match-1/seg-0000")).unwrap(),
            b"segment"
        );
        let again = copy_recording(&from, &dir.join("match-1")).unwrap_err();
        assert_eq!(again.kind(), io::ErrorKind::AlreadyExists);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(unix)]
    #[test]
    fn links_planted_in_the_matches_directory_are_not_followed() {
        let dir = scratch("links");
        let matches = MatchesDir::new(dir.join("matches"));
        let secret = dir.join("secret");
        std::fs::create_dir_all(&secret).unwrap();
        std::fs::write(secret.join("token-key"), b"do not read").unwrap();
        std::fs::create_dir_all(matches.path().join("match-1")).unwrap();
        std::os::unix::fs::symlink(&secret, matches.path().join("match-2")).unwrap();
        std::os::unix::fs::symlink(secret.join("token-key"), matches.path().join("match-1/seg"))
            .unwrap();
        let listed = matches.list().unwrap();
        assert_eq!(listed.len(), 1, "the linked directory is not a match");
        assert_eq!(listed[0].files, 0, "the linked file is not a file of it");
        let linked = MatchName::new("match-2").unwrap();
        assert!(matches.read(&linked, 0, 0).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
