//! The C and C# samples, built against `include/inertia.h` and
//! `libinertia`, join a real server and see its world move: the C one
//! with the system's C compiler, the C# one with Mono (`mcs`, `mono`;
//! `.ci/run` installs them), through P/Invoke as Unity does. Without a
//! compiler the test says so and passes, except under CI, where a missing
//! tool fails it.

use std::path::{Path, PathBuf};
use std::process::Command;

use inertia_tests::server::{start_server, temp_data_dir, test_config, token};

/// The folder cargo put `libinertia` in. `cargo test` leaves the shared
/// library in `deps/`, beside the test binary; `cargo build` also copies
/// it up to `target/<profile>/`.
fn library_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test's path");
    let deps = exe.parent().expect("target/<profile>/deps/<test>");
    let candidates = [Some(deps), deps.parent()];
    let found = candidates
        .into_iter()
        .flatten()
        .find(|dir| dir.join("libinertia.so").exists() || dir.join("libinertia.dylib").exists());
    found
        .unwrap_or_else(|| panic!("libinertia is built beside the tests in {}", deps.display()))
        .to_path_buf()
}

/// Whether `tool` runs; false (the test then passes with a note) outside
/// CI; a failure under CI.
fn have(tool: &str, args: &[&str]) -> bool {
    let ok = Command::new(tool)
        .args(args)
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "{tool} is missing under CI (.ci/run installs it)"
        );
        eprintln!("{tool} is not installed here: this sample is not run (.ci/run installs it)");
    }
    ok
}

/// Runs a built sample against a fresh server on the moving test scene,
/// and returns what it printed; panics unless it exits 0.
async fn run_sample(what: &str, program: Vec<String>, env: Vec<(String, String)>) -> String {
    let server = start_server(test_config(Some("moving.ron"), what)).await;
    let (addr, token) = token(&server, 7);
    let token_hex = hex::encode(token.to_bytes());
    let output = tokio::task::spawn_blocking(move || {
        let (cmd, args) = program.split_first().expect("a program");
        Command::new(cmd)
            .args(args)
            .args([addr.to_string(), token_hex, "3".into()])
            .envs(env)
            .output()
            .expect("the sample starts")
    })
    .await
    .expect("joined");
    server.shutdown().await;
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "{what} failed ({}):\n{stdout}\n{stderr}",
        output.status
    );
    stdout
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_c_sample_joins_a_server_and_sees_its_world_move() {
    if !have("cc", &["--version"]) {
        return;
    }
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib = library_dir();
    let out = temp_data_dir("ffi-c-build");
    std::fs::create_dir_all(&out).unwrap();
    let exe = out.join("print_world");
    let built = Command::new("cc")
        .args([
            "-std=c11",
            "-D_POSIX_C_SOURCE=200809L",
            "-Wall",
            "-Wextra",
            "-Werror",
        ])
        .arg("-I")
        .arg(crate_dir.join("include"))
        .arg(crate_dir.join("examples/c/print_world.c"))
        .arg(format!("-L{}", lib.display()))
        .arg("-linertia")
        .arg(format!("-Wl,-rpath,{}", lib.display()))
        .arg("-o")
        .arg(&exe)
        .output()
        .expect("cc runs");
    assert!(
        built.status.success(),
        "the C sample builds:\n{}",
        String::from_utf8_lossy(&built.stderr)
    );
    // The library beside the tests first: cargo's own search path for a
    // test may name another build's copy.
    let printed = run_sample(
        "ffi-c",
        vec![exe.display().to_string()],
        vec![("LD_LIBRARY_PATH".into(), lib.display().to_string())],
    )
    .await;
    assert!(printed.contains("joined"), "{printed}");
    assert!(printed.contains("entities in the picture"), "{printed}");
    assert!(printed.contains("saw the world move"), "{printed}");
    assert!(printed.contains("on time"), "{printed}");
    assert!(printed.contains("prediction: error"), "{printed}");
    assert!(printed.contains("heard 1 chat line"), "{printed}");
    assert!(printed.contains("match players = 1"), "{printed}");
    assert!(printed.contains("replay ended: finished"), "{printed}");
    println!("{printed}");
    let _ = std::fs::remove_dir_all(&out);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_csharp_sample_joins_a_server_through_p_invoke() {
    if !have("mcs", &["--version"]) || !have("mono", &["--version"]) {
        return;
    }
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib = library_dir();
    let out = temp_data_dir("ffi-cs-build");
    std::fs::create_dir_all(&out).unwrap();
    let exe = out.join("PrintWorld.exe");
    let built = Command::new("mcs")
        .arg(format!("-out:{}", exe.display()))
        .arg(crate_dir.join("examples/csharp/Inertia.cs"))
        .arg(crate_dir.join("examples/csharp/PrintWorld.cs"))
        .output()
        .expect("mcs runs");
    assert!(
        built.status.success(),
        "the C# sample builds:\n{}{}",
        String::from_utf8_lossy(&built.stdout),
        String::from_utf8_lossy(&built.stderr)
    );
    let printed = run_sample(
        "ffi-cs",
        vec!["mono".into(), exe.display().to_string()],
        vec![("LD_LIBRARY_PATH".into(), lib.display().to_string())],
    )
    .await;
    assert!(printed.contains("joined"), "{printed}");
    assert!(printed.contains("saw the world move"), "{printed}");
    assert!(printed.contains("heard 1 chat line"), "{printed}");
    assert!(printed.contains("match players = 1"), "{printed}");
    assert!(printed.contains("replay ended: finished"), "{printed}");
    let _ = std::fs::remove_dir_all(&out);
}
