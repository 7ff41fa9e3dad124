//! The server's command line keeps the conventions people script against:
//! `--help` goes to standard output with status 0, `--version` prints the
//! server's and the protocol's version, under the name of the binary that
//! runs (the stock server, or a game's own built on the library).

use std::process::Command;

use inertia_protocol::PROTOCOL_VERSION;

fn run(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_inertia-server"))
        .args(args)
        .env_remove("INERTIA_CONFIG")
        .output()
        .expect("inertia-server runs")
}

#[test]
fn issue_43_help_goes_to_standard_output_with_status_0() {
    let out = run(&["--help"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "status {:?}: {stdout}", out.status);
    assert!(stdout.contains("Usage: inertia-server"), "{stdout}");
    assert!(stdout.contains("--config <FILE>"), "{stdout}");
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn issue_43_version_names_the_server_and_the_protocol() {
    let out = run(&["--version"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "status {:?}: {stdout}", out.status);
    assert_eq!(
        stdout.trim(),
        format!(
            "inertia-server {} (protocol {PROTOCOL_VERSION})",
            env!("CARGO_PKG_VERSION")
        )
    );
    // A game's own binary says what it is built on.
    let line =
        inertia_server::config::ServerArgs::parse_command_line(["inertia-football", "--version"])
            .expect_err("--version ends the parse")
            .to_string();
    assert_eq!(
        line.trim(),
        format!(
            "inertia-football built on inertia-server {}, protocol {PROTOCOL_VERSION}",
            env!("CARGO_PKG_VERSION")
        )
    );
}

#[test]
fn issue_43_a_bad_option_is_refused_on_standard_error_with_status_2() {
    let out = run(&["--no-such-option"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--no-such-option"), "{stderr}");
}

#[test]
fn issue_43_help_to_an_output_that_cannot_take_it_is_an_error_not_a_panic() {
    // `inertia-server --help | head -1` closes the pipe; a full disk
    // refuses the write. Either way the process says so (or, for a closed
    // pipe, nothing) and exits, never panics.
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .expect("/dev/full");
    let out = Command::new(env!("CARGO_BIN_EXE_inertia-server"))
        .arg("--help")
        .env_remove("INERTIA_CONFIG")
        .stdout(full)
        .output()
        .expect("inertia-server runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("inertia-server: cannot write"), "{stderr}");
}
