//! Runs every suite of the real binary in `--quick --json` mode and checks
//! the output contract: stdout is nothing but JSON objects, one per case,
//! each with `suite`, `machine` and `threads`, and the suite's own fields
//! present and sane.

use std::process::Command;

use serde_json::{Map, Value};

fn run(suite: &str) -> Vec<Map<String, Value>> {
    let out = Command::new(env!("CARGO_BIN_EXE_inertia-bench"))
        .args([suite, "--json", "--quick"])
        .output()
        .expect("run inertia-bench");
    assert!(
        out.status.success(),
        "{suite} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).expect("utf-8 stdout");
    let lines: Vec<Map<String, Value>> = stdout
        .lines()
        .map(|l| match serde_json::from_str::<Value>(l) {
            Ok(Value::Object(m)) => m,
            other => panic!("{suite}: not a JSON object line: {l:?} ({other:?})"),
        })
        .collect();
    assert!(!lines.is_empty(), "{suite} printed nothing");
    for m in &lines {
        assert_eq!(m["suite"], suite, "{m:?}");
        let machine = m["machine"].as_object().expect("machine object");
        assert!(!machine["cpu"].as_str().expect("cpu string").is_empty());
        assert!(machine["logical_cores"].as_u64().expect("cores") >= 1);
        assert!(m["threads"].as_u64().expect("threads") >= 1, "{m:?}");
    }
    lines
}

/// Runs `inertia-bench SUITE --plot DIR --from RESULTS`.
fn plot_from(
    suite: &str,
    dir: &std::path::Path,
    results: &std::path::Path,
) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_inertia-bench"))
        .args([suite, "--plot"])
        .arg(dir)
        .arg("--from")
        .arg(results)
        .output()
        .expect("run inertia-bench")
}

fn num(m: &Map<String, Value>, k: &str) -> f64 {
    m.get(k)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("field {k} missing or not a number in {m:?}"))
}

fn positive(m: &Map<String, Value>, k: &str) -> f64 {
    let x = num(m, k);
    assert!(x.is_finite() && x > 0.0, "{k} = {x} in {m:?}");
    x
}

#[test]
fn integrators_suite() {
    let lines = run("integrators");
    let names: Vec<&str> = lines
        .iter()
        .map(|m| m["integrator"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "forward_euler",
            "symplectic_euler",
            "leapfrog",
            "verlet",
            "rk4"
        ]
    );
    for m in &lines {
        let expected = num(m, "expected_order");
        for k in ["order_oscillator", "order_kepler"] {
            let order = num(m, k);
            assert!((order - expected).abs() < 0.3, "{k} = {order} in {m:?}");
        }
        let name = m["integrator"].as_str().unwrap();
        match name {
            // Grows by (1 + (ω dt)²) per step: huge, or overflowed (null).
            "forward_euler" => assert!(m["energy_drift"].as_f64().is_none_or(|d| d > 1.0)),
            "rk4" => assert!(positive(m, "energy_drift") < 1e-3, "{m:?}"),
            _ => assert!(num(m, "energy_drift") < 0.05, "{m:?}"),
        }
    }
}

#[test]
fn particles_suite() {
    let lines = run("particles");
    let mut cpu_threads = Vec::new();
    let mut gpu = 0;
    let mut nbody = 0;
    for m in &lines {
        let case = m["case"].as_str().expect("case");
        if case.starts_with("nbody_") {
            nbody += 1;
            positive(m, "ms_per_step");
            continue;
        }
        assert!(positive(m, "particles") >= 1000.0);
        match m["backend"].as_str().expect("backend") {
            "cpu" => {
                cpu_threads.push(m["threads"].as_u64().unwrap());
                for k in [
                    "ns_per_particle_step",
                    "bytes_per_s",
                    "copy_bytes_per_s",
                    "fraction_of_copy",
                ] {
                    positive(m, k);
                }
                // A timing ratio: its size is the bench's to judge (a
                // loaded machine can slow the copy it is measured against
                // many times over), so only its sanity is checked here.
                assert!(num(m, "fraction_of_copy").is_finite(), "{m:?}");
                assert_eq!(num(m, "quarantined"), 0.0, "{m:?}");
                assert!(m["energy_accounting"].is_boolean());
            }
            "gpu" => {
                gpu += 1;
                // Either the GPU ran and agrees with the CPU to f32
                // precision, or the record says why it did not.
                if m.get("error").is_none() {
                    positive(m, "ns_per_particle_step");
                    positive(m, "fraction_of_copy");
                    assert!(num(m, "max_abs_diff_vs_cpu") < 1.0, "{m:?}");
                } else {
                    assert!(!m["error"].as_str().unwrap().is_empty());
                }
            }
            other => panic!("unknown backend {other}"),
        }
    }
    assert_eq!(gpu, 3, "one GPU record per scene");
    assert!(cpu_threads.contains(&1) && cpu_threads.contains(&2));
    assert_eq!(cpu_threads.len() % 3, 0, "each scene at each thread count");
    assert!(nbody >= 4, "the n-body case is part of the particles suite");
}

#[test]
fn nbody_suite() {
    let lines = run("nbody");
    let exact = lines.iter().filter(|m| m["method"] == "exact").count();
    assert!(exact >= 2, "exact at 1 and 2 threads");
    for m in &lines {
        positive(m, "ms_per_step");
        positive(m, "bodies");
        if m["method"] == "barnes_hut" {
            let theta = positive(m, "theta");
            let rms = positive(m, "rms_rel_force_error");
            let max = positive(m, "max_rel_force_error");
            assert!(rms <= max, "{m:?}");
            assert!(rms < 0.05 * theta * theta + 1e-6, "{m:?}");
            positive(m, "rms_error_bound");
        } else {
            assert_eq!(num(m, "rms_rel_force_error"), 0.0);
        }
    }
}

#[test]
fn physics_suite() {
    let all = run("physics");
    // The demo scene is ours alone: one record per thread count, no rapier.
    let (demo, lines): (Vec<_>, Vec<_>) = all.into_iter().partition(|m| m["scene"] == "demo");
    assert!(demo.len() >= 2, "the demo at 1 and 2 threads: {demo:?}");
    for m in &demo {
        for k in ["bodies", "particles", "steps", "ours_ms_median", "dt"] {
            positive(m, k);
        }
        assert!(num(m, "ours_ms_median") <= num(m, "ours_ms_p99"), "{m:?}");
        assert_eq!(num(m, "ours_quarantined"), 0.0, "{m:?}");
        assert!(m.get("rapier_ms_median").is_none(), "{m:?}");
        let stages = m["ours_stage_ms"].as_object().expect("stages");
        assert!(stages["total"].as_f64().is_some_and(|t| t > 0.0), "{m:?}");
    }
    let scenes = [
        "pyramid_4",
        "pyramid_8",
        "many_pyramids_4x4",
        "balls_64",
        "mixed_pile_48",
        "convex_pile_48",
        "joint_grid_6x6",
        "ragdolls_4",
    ];
    let numeric = [
        "bodies",
        "static_bodies",
        "joints",
        "steps",
        "warmup_steps",
        "dt",
        "solver_iterations",
        "ours_ms_median",
        "ours_ms_p99",
        "rapier_ms_median",
        "rapier_ms_p99",
        "ratio",
        "ours_max_penetration_mm",
        "rapier_max_penetration_mm",
        "rapier_manifold_penetration_mm",
        "ours_awake_at_end",
        "rapier_awake_at_end",
        "ours_fell_through",
        "rapier_fell_through",
        "ours_quarantined",
        "rapier_quarantined",
    ];
    assert_eq!(
        lines.len(),
        scenes.len() * 4,
        "each scene at 1 and 2 threads, sleeping off and on"
    );
    for m in &lines {
        let scene = m["scene"].as_str().expect("scene");
        assert!(scenes.contains(&scene), "unexpected scene {scene}");
        for k in numeric {
            let x = num(m, k);
            assert!(x.is_finite() && x >= 0.0, "{k} = {x} in {m:?}");
        }
        for k in [
            "ours_ms_median",
            "rapier_ms_median",
            "ratio",
            "bodies",
            "steps",
        ] {
            positive(m, k);
        }
        assert!(num(m, "ours_ms_median") <= num(m, "ours_ms_p99"), "{m:?}");
        assert!(
            num(m, "rapier_ms_median") <= num(m, "rapier_ms_p99"),
            "{m:?}"
        );
        for k in ["sleeping", "target_cpu_native", "avx2"] {
            assert!(m[k].is_boolean(), "{k} in {m:?}");
        }
        // Drift is measured for the scenes that start at rest, `null` for the others.
        let at_rest = scene.contains("pyramid") || scene.starts_with("joint_grid");
        for k in ["ours_drift_mm", "rapier_drift_mm"] {
            if at_rest {
                let d = num(m, k);
                assert!(
                    d.is_finite() && (0.0..100.0).contains(&d),
                    "{k} = {d} in {m:?}"
                );
            } else {
                assert!(m[k].is_null(), "{k} in {m:?}");
            }
        }
        // The share of manifolds used again: a fraction, or null where
        // there were none.
        let recycled = &m["ours_recycled"];
        assert!(
            recycled.is_null() || recycled.as_f64().is_some_and(|x| (0.0..=1.0).contains(&x)),
            "ours_recycled in {m:?}"
        );
        // Nothing blew up, nothing fell through the ground.
        for k in [
            "ours_fell_through",
            "rapier_fell_through",
            "ours_quarantined",
            "rapier_quarantined",
        ] {
            assert_eq!(num(m, k), 0.0, "{k} in {m:?}");
        }
        let bodies = num(m, "bodies");
        assert!(num(m, "ours_awake_at_end") <= bodies && num(m, "rapier_awake_at_end") <= bodies);
        if m["sleeping"] == false {
            assert_eq!(num(m, "ours_awake_at_end"), bodies, "{m:?}");
            assert_eq!(num(m, "rapier_awake_at_end"), bodies, "{m:?}");
        }
    }
    let threads: Vec<u64> = lines
        .iter()
        .map(|m| m["threads"].as_u64().unwrap())
        .collect();
    assert!(threads.contains(&1) && threads.contains(&2));
}

#[test]
fn replay_suite() {
    let lines = run("replay");
    assert_eq!(lines.len(), 1, "one record per keyframe interval");
    let m = &lines[0];
    assert_eq!(m["case"], "replay_k120");
    assert_eq!(num(m, "keyframe_ticks"), 120.0);
    assert_eq!(num(m, "bodies"), 300.0);
    assert_eq!(num(m, "bots"), 8.0);
    assert_eq!(num(m, "ticks"), 720.0);
    // Nothing re-simulated differed from what was recorded.
    assert_eq!(num(m, "seek_hash_mismatches"), 0.0, "{m:?}");
    assert_eq!(num(m, "verify_mismatches"), 0.0, "{m:?}");
    assert_eq!(num(m, "verify_hashes_checked"), 720.0, "{m:?}");
    assert_eq!(num(m, "inputs_rejected"), 0.0, "{m:?}");
    // 720 ticks at K = 120: the session's keyframe, six more and the last.
    assert_eq!(num(m, "keyframes"), 8.0, "{m:?}");
    for k in [
        "bytes",
        "bytes_per_hour",
        "keyframe_bytes_mean",
        "keyframe_raw_bytes_mean",
        "keyframe_world_bytes_mean",
        "keyframe_table_bytes_mean",
        "journal_bytes_per_hour",
        "hash_bytes_per_hour",
        "seek_ms_median",
        "seek_ms_p99",
        "seek_ms_max",
        "verify_ticks_per_s",
        "tick_ms_mean",
    ] {
        positive(m, k);
    }
    let parts = num(m, "keyframe_bytes_per_hour")
        + num(m, "journal_bytes_per_hour")
        + num(m, "hash_bytes_per_hour")
        + num(m, "other_bytes_per_hour");
    assert!(
        (parts - num(m, "bytes_per_hour")).abs() < 1.0,
        "the parts add up: {parts} in {m:?}"
    );
    assert!(num(m, "seek_ms_median") <= num(m, "seek_ms_p99"));
    assert!(num(m, "seek_ms_p99") <= num(m, "seek_ms_max"));
    // A seek never re-simulates more than one keyframe interval.
    assert!(num(m, "seek_resimulated_max") < 120.0, "{m:?}");
}

/// `--plot DIR --from FILE` draws a committed results file's records
/// without running the suite; a file that does not parse is an error.
#[test]
fn plots_are_drawn_from_a_results_file() {
    let dir = std::env::temp_dir().join(format!("inertia-bench-plot-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let results = concat!(env!("CARGO_MANIFEST_DIR"), "/results/xeon-2core.jsonl");
    for suite in ["physics", "capacity"] {
        let out = plot_from(suite, &dir, results.as_ref());
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let svg = std::fs::read_to_string(dir.join(format!("{suite}.svg"))).expect("the plot");
        assert!(svg.starts_with("<svg") && svg.contains("Xeon"), "{suite}");
    }
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.jsonl");
    std::fs::write(&bad, "not json\n").unwrap();
    let out = plot_from("physics", &dir, &bad);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("bad.jsonl:1"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bandwidth_suite_gives_its_seconds_in_order() {
    let all = run("bandwidth");
    let m = &all[0];
    let per_second = m["kbps_per_s"].as_array().expect("kbps_per_s");
    assert_eq!(
        per_second.len() as u64,
        m["seconds"].as_u64().expect("seconds")
    );
    assert!(per_second
        .iter()
        .all(|k| k.as_f64().expect("a number") > 0.0));
    let max = per_second
        .iter()
        .filter_map(Value::as_f64)
        .fold(0.0, f64::max);
    assert_eq!(max, num(m, "kbps_max_1s"));
    // The properties cases: both loads, both losses, with their cost and
    // delivery.
    let cases: Vec<&str> = all[1..]
        .iter()
        .map(|m| m["case"].as_str().unwrap())
        .collect();
    assert_eq!(
        cases,
        [
            "properties_1000",
            "properties_1000",
            "properties_1000_light",
            "properties_1000_light"
        ]
    );
    for m in &all[1..] {
        assert!(num(m, "bits_per_changed_property") > 0.0, "{m:?}");
        assert!(num(m, "delivery_periods_p99") >= 0.0, "{m:?}");
    }
}

#[test]
fn soft_suite() {
    let all = run("soft");
    let (gpu, lines): (Vec<_>, Vec<_>) = all.iter().cloned().partition(|m| m["backend"] == "gpu");
    let cases: Vec<(&str, u64)> = lines
        .iter()
        .map(|m| (m["case"].as_str().unwrap(), m["threads"].as_u64().unwrap()))
        .collect();
    assert_eq!(
        cases,
        [
            ("cloth_32", 1),
            ("cloth_32", 2),
            ("jelly_6", 1),
            ("jelly_6", 2),
            ("fluid_2k", 1),
            ("fluid_2k", 2)
        ]
    );
    for m in &lines {
        assert_eq!(m["backend"], "cpu");
        positive(m, "ms_per_step");
        assert!(m["particles"].as_u64().unwrap() > 0 && m["constraints"].as_u64().unwrap() > 0);
        assert_eq!(m["same_bits_on_1_and_2_threads"], true, "{m:?}");
        let share = num(m, "soft_share");
        assert!((0.0..=1.0).contains(&share), "{m:?}");
    }
    // The cloth, the jelly and the fluid on the GPU: a row each either
    // way, their figures when they ran.
    let gpu_cases: Vec<&str> = gpu.iter().map(|m| m["case"].as_str().unwrap()).collect();
    assert_eq!(gpu_cases, ["cloth_32", "jelly_6", "fluid_2k"], "{gpu:?}");
    for soft in &gpu[..2] {
        if soft.get("error").is_none() {
            positive(soft, "ms_per_step");
            let diff = num(soft, "max_abs_diff_vs_cpu");
            assert!((0.0..2e-3).contains(&diff), "{diff}");
        }
    }
    if gpu[1].get("error").is_none() {
        assert!(num(&gpu[1], "volume_kept") > 0.9, "{:?}", gpu[1]);
    }
    if gpu[2].get("error").is_none() {
        positive(&gpu[2], "ms_per_step");
        assert!(num(&gpu[2], "density_error").abs() < 0.2, "{:?}", gpu[2]);
        // Eight steps of a breaking dam: still close particle by particle.
        let diff = num(&gpu[2], "max_abs_diff_vs_cpu");
        assert!((0.0..1e-3).contains(&diff), "{diff}");
    }
    let strain = num(&lines[0], "max_strain");
    assert!((0.0..1.0).contains(&strain), "{strain}");
    let kept = num(&lines[2], "volume_kept");
    assert!((0.9..1.1).contains(&kept), "{kept}");
    let error = num(&lines[4], "density_error");
    assert!(error.abs() < 0.2, "{error}");
    // Its picture, from a results file of these records.
    let dir = std::env::temp_dir().join(format!("inertia-bench-soft-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let results = dir.join("soft.jsonl");
    let text: String = all
        .iter()
        .map(|m| serde_json::to_string(m).unwrap() + "\n")
        .collect();
    std::fs::write(&results, text).unwrap();
    let out = plot_from("soft", &dir, &results);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let svg = std::fs::read_to_string(dir.join("soft.svg")).expect("the plot");
    assert!(svg.starts_with("<svg") && svg.contains("cloth_32"));
    let _ = std::fs::remove_dir_all(&dir);
}
