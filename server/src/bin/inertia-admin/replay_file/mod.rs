//! `inertia-admin replay-file`: offline tools for a recording directory
//! (the segment files the server writes to `<data-dir>/recording/`, see
//! `inertia_server::record`). Nothing here talks to a server.
//!
//! - [`inspect`]: what a recording holds — segments, sessions, ticks,
//!   simulated duration, records by kind, bytes, damage;
//! - [`export`]: the records of a tick range as JSON lines;
//! - [`verify`]: re-simulate the recording and check every stored hash.
//!
//! Exit status: 0 when the command did what was asked (and, for `verify`,
//! every hash matched); 1 when the recording is damaged or does not
//! re-simulate to its hashes; 2 for misuse (a path that does not exist or
//! holds no recording, a bad tick range, an output file that cannot be
//! made).

mod export;
mod inspect;
mod scan;
mod verify;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Subcommand;

use crate::Failure;

/// The `replay-file` subcommands.
#[derive(Debug, Subcommand)]
pub enum ReplayFileCmd {
    /// Summarise a recording: segments, sessions, tick range, simulated
    /// duration, records by kind, bytes, damage.
    Inspect {
        /// The recording directory (or one segment file).
        dir: PathBuf,
    },
    /// Print the records of a tick range as JSON lines, one object per
    /// record.
    Export {
        /// The recording directory (or one segment file).
        dir: PathBuf,
        /// The first tick to export (default: the first recorded).
        #[arg(long, value_name = "TICK")]
        from: Option<u64>,
        /// The last tick to export (default: the last recorded).
        #[arg(long, value_name = "TICK")]
        to: Option<u64>,
        /// Write the lines to FILE instead of stdout.
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Re-simulate the recording from its first keyframe and check every
    /// stored tick hash and keyframe.
    Verify {
        /// The recording directory (or one segment file).
        dir: PathBuf,
    },
}

/// Runs one `replay-file` command, printing its result (one JSON object
/// with `json`), and gives the exit status. A command that printed its
/// result says itself why it fails (exit 1 after a damaged summary or a
/// mismatching verify); a command that could not run fails with a
/// [`Failure`].
pub fn run(cmd: &ReplayFileCmd, json: bool) -> ExitCode {
    let result = match cmd {
        ReplayFileCmd::Inspect { dir } => inspect::run(dir, json),
        ReplayFileCmd::Export { dir, from, to, out } => {
            export::run(dir, *from, *to, out.as_deref(), json)
        }
        ReplayFileCmd::Verify { dir } => verify::run(dir, json),
    };
    match result {
        Ok(code) => code,
        Err(f) => f.report(json),
    }
}

/// A failure of misuse (exit 2).
fn misuse(kind: &'static str, message: String) -> Failure {
    Failure {
        code: 2,
        kind,
        message,
    }
}

/// A failure of the data (exit 1).
fn data_error(kind: &'static str, message: String) -> Failure {
    Failure {
        code: 1,
        kind,
        message,
    }
}

/// A 64-bit hash as 16 lower-case hex digits (JSON numbers lose bits past
/// 2^53 in many readers).
fn hex(hash: u64) -> String {
    format!("{hash:016x}")
}

/// A byte count for people: exact, with a binary-prefixed size beside it
/// past 1 KiB (`123456 bytes (120.6 KiB)`).
fn bytes_text(n: u64) -> String {
    if n < 1024 {
        return format!("{n} bytes");
    }
    format!("{n} bytes ({})", size_text(n))
}

/// A byte count for people, short: `312 bytes`, `120.6 KiB`, `3.0 MiB`.
fn size_text(n: u64) -> String {
    const UNITS: [&str; 4] = ["KiB", "MiB", "GiB", "TiB"];
    if n < 1024 {
        return format!("{n} bytes");
    }
    let mut v = n as f64 / 1024.0;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    format!("{v:.1} {}", UNITS[unit])
}

/// `n` and the noun, plural unless `n` is 1 (`1 join`, `3 joins`).
fn count(n: u64, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts_read_for_people() {
        assert_eq!(bytes_text(0), "0 bytes");
        assert_eq!(bytes_text(1023), "1023 bytes");
        assert_eq!(bytes_text(1536), "1536 bytes (1.5 KiB)");
        assert_eq!(bytes_text(3 << 20), "3145728 bytes (3.0 MiB)");
        assert_eq!(size_text(100), "100 bytes");
        assert_eq!(size_text(1 << 30), "1.0 GiB");
        assert_eq!(count(1, "join", "joins"), "1 join");
        assert_eq!(count(2, "join", "joins"), "2 joins");
        assert_eq!(hex(0xfeed), "000000000000feed");
    }
}
