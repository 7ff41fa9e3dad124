//! Each match's recording is kept under its own name in the data
//! directory when the match ends, and an operator lists and fetches it
//! through the admin channel (`inertia-admin matches`, `fetch-recording`),
//! then verifies it offline.

#![cfg(unix)]

use crate::common;

use std::path::Path;
use std::time::{Duration, Instant};

use common::{admin, DevServer};

fn json(out: &std::process::Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "inertia-admin failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .expect("a directory")
        .map(|e| {
            let e = e.expect("an entry");
            (
                e.file_name().into_string().expect("utf-8"),
                std::fs::read(e.path()).expect("readable"),
            )
        })
        .collect();
    out.sort();
    out
}

#[test]
fn issue_14_a_finished_match_is_kept_listed_fetched_and_verifies() {
    let dir = std::env::temp_dir().join(format!("inertia-matches-e2e-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // A one-second match: the server ends it and exits by itself.
    let mut first = DevServer::start_in(dir.clone(), &["--match-seconds", "1"]);
    let started = Instant::now();
    let status = loop {
        if let Some(status) = first.child.try_wait().expect("wait") {
            break status;
        }
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the match did not end"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(status.success(), "{status:?}");
    // The data directory is the next server's: not removed with this one.
    std::mem::forget(first);
    assert!(
        !dir.join("recording").exists(),
        "moved under the match's name"
    );
    let kept: Vec<_> = std::fs::read_dir(dir.join("matches"))
        .expect("the matches directory")
        .map(|e| e.expect("entry").file_name().into_string().expect("utf-8"))
        .collect();
    assert_eq!(kept.len(), 1);
    assert!(kept[0].starts_with("match-"), "{kept:?}");

    // The next match's server lists and serves it.
    let server = DevServer::start_in(dir.clone(), &[]);
    let listed = json(&admin(&server.credentials, &["--json", "matches"]));
    let matches = listed["matches"].as_array().expect("a list");
    assert_eq!(matches.len(), 1);
    assert_eq!(matches[0]["name"], kept[0].as_str());
    assert!(matches[0]["bytes"].as_u64().expect("bytes") > 0);

    let out = dir.with_extension("fetched");
    let _ = std::fs::remove_dir_all(&out);
    let fetched = json(&admin(
        &server.credentials,
        &[
            "--json",
            "fetch-recording",
            &kept[0],
            "--out",
            out.to_str().expect("utf-8"),
        ],
    ));
    assert_eq!(fetched["files"], matches[0]["files"]);
    assert_eq!(fetched["bytes"], matches[0]["bytes"]);
    assert_eq!(files(&out), files(&dir.join("matches").join(&kept[0])));
    let verified = admin(
        &server.credentials,
        &["replay-file", "verify", out.to_str().expect("utf-8")],
    );
    assert!(
        verified.status.success(),
        "{}",
        String::from_utf8_lossy(&verified.stdout)
    );

    // Names that are paths, and matches that are not there, are refused.
    let path = admin(
        &server.credentials,
        &["fetch-recording", "../recording", "--out", "/tmp/x"],
    );
    assert_eq!(path.status.code(), Some(2), "a path is not a match name");
    let absent = admin(
        &server.credentials,
        &[
            "--json",
            "fetch-recording",
            "match-1",
            "--out",
            out.with_extension("absent").to_str().unwrap(),
        ],
    );
    assert_eq!(absent.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&absent.stdout).contains("not_found"));
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(out.with_extension("absent"));
}
