//! The configuration's sources, precedence and checks.

use std::collections::BTreeMap;
use std::path::Path;

use super::*;

fn env_of(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
    let map: BTreeMap<String, String> = pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    move |k| map.get(k).cloned()
}

fn temp_file(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("inertia-config-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn the_orchestrator_is_agones_where_agones_sets_its_port() {
    let none = ServerConfig::from_args(["inertia-server"], env_of(&[])).unwrap();
    assert_eq!(none.orchestrating(), Orchestrating::Standalone);
    let agones_env = [("AGONES_SDK_HTTP_PORT", "9400")];
    let auto = ServerConfig::from_args(["inertia-server"], env_of(&agones_env)).unwrap();
    assert_eq!(
        auto.orchestrating(),
        Orchestrating::Agones { sdk_port: 9400 }
    );
    let off = ServerConfig::from_args(
        ["inertia-server", "--orchestrator", "standalone"],
        env_of(&agones_env),
    )
    .unwrap();
    assert_eq!(off.orchestrating(), Orchestrating::Standalone);
    let asked = ServerConfig::from_args(
        ["inertia-server"],
        env_of(&[("INERTIA_ORCHESTRATOR", "agones")]),
    )
    .unwrap();
    assert_eq!(
        asked.orchestrating(),
        Orchestrating::Agones {
            sdk_port: crate::orchestrator::sdk::DEFAULT_HTTP_PORT
        }
    );
    for bad in ["0", "70000", "port"] {
        let e =
            ServerConfig::from_args(["inertia-server"], env_of(&[("AGONES_SDK_HTTP_PORT", bad)]))
                .unwrap_err();
        assert!(e.to_string().contains("AGONES_SDK_HTTP_PORT"), "{e}");
    }
    assert!(
        ServerConfig::from_args(["inertia-server", "--orchestrator", "k8s"], env_of(&[])).is_err()
    );
    let timed =
        ServerConfig::from_args(["inertia-server", "--match-seconds", "900"], env_of(&[])).unwrap();
    assert_eq!(timed.match_seconds, Some(900));
    for bad in ["0", "86401"] {
        let e = ServerConfig::from_args(["inertia-server", "--match-seconds", bad], env_of(&[]))
            .unwrap_err();
        assert!(e.to_string().contains("match_seconds"), "{e}");
    }
}

#[test]
fn defaults_are_dev_mode_on_loopback() {
    let c = ServerConfig::from_args(["inertia-server"], env_of(&[])).unwrap();
    assert_eq!(c, ServerConfig::default());
    assert!(c.dev_mode());
    assert_eq!(c.listen_addr(), "127.0.0.1:7777".parse().unwrap());
    assert_eq!(c.metrics, "127.0.0.1:9100".parse().unwrap());
    assert_eq!(
        (c.tick_hz, c.snapshot_hz, c.max_catch_up_ticks),
        (60, 30, 5)
    );
}

#[test]
fn credentials_leave_dev_mode_and_listen_everywhere() {
    let c = ServerConfig::from_args(
        [
            "s",
            "--key-file",
            "k",
            "--cert-file",
            "c",
            "--cert-key-file",
            "ck",
        ],
        env_of(&[]),
    )
    .unwrap();
    assert!(!c.dev_mode());
    assert_eq!(c.listen_addr(), "0.0.0.0:7777".parse().unwrap());
}

#[test]
fn command_line_beats_environment_beats_file_beats_default() {
    let file = temp_file(
        "layers.toml",
        "tick_hz = 100\nsnapshot_hz = 20\nmax_clients = 10\nlog_format = \"json\"\n",
    );
    let file_s = file.to_str().unwrap();
    let env = env_of(&[
        ("INERTIA_TICK_HZ", "120"),
        ("INERTIA_SNAPSHOT_HZ", "40"),
        (
            "INERTIA_CONFIG",
            "/nonexistent/ignored-because-cli-names-one.toml",
        ),
    ]);
    let c = ServerConfig::from_args(["s", "--config", file_s, "--tick-hz", "200"], env).unwrap();
    assert_eq!(c.tick_hz, 200, "command line wins");
    assert_eq!(c.snapshot_hz, 40, "environment beats the file");
    assert_eq!(c.max_clients, 10, "file beats the default");
    assert_eq!(c.log_format, LogFormat::Json);
    assert_eq!(c.client_budget_kbps, DEFAULT_CLIENT_BUDGET_KBPS, "default");
}

#[test]
fn config_file_can_come_from_the_environment() {
    let file = temp_file("env.toml", "scene = \"scenes/pyramid.json\"\n");
    let env = env_of(&[("INERTIA_CONFIG", file.to_str().unwrap())]);
    let c = ServerConfig::from_args(["s"], env).unwrap();
    assert_eq!(c.scene, Some(PathBuf::from("scenes/pyramid.json")));
}

#[test]
fn bad_toml_names_the_key() {
    let e = parse_toml(Path::new("x.toml"), "tick_hz = \"fast\"\n").unwrap_err();
    match e {
        ConfigError::Toml { key, .. } => assert_eq!(key, "tick_hz"),
        e => panic!("{e}"),
    }
    let e = parse_toml(Path::new("x.toml"), "tick_hz = 60\nspeed = 3\n").unwrap_err();
    assert!(e.to_string().contains("speed"), "{e}");
    let e = parse_toml(Path::new("x.toml"), "listen = \"nowhere\"\n").unwrap_err();
    match e {
        ConfigError::Toml { key, .. } => assert_eq!(key, "listen"),
        e => panic!("{e}"),
    }
}

#[test]
fn bad_environment_names_the_variable() {
    let e = ServerConfig::from_args(["s"], env_of(&[("INERTIA_LISTEN", "port 7")])).unwrap_err();
    assert!(
        matches!(&e, ConfigError::Env { var, .. } if var == "INERTIA_LISTEN"),
        "{e}"
    );
}

#[test]
fn ranges_are_checked() {
    let run = |args: &[&str]| {
        let mut a = vec!["s"];
        a.extend_from_slice(args);
        ServerConfig::from_args(a, env_of(&[]))
    };
    assert!(matches!(
        run(&["--tick-hz", "0"]),
        Err(ConfigError::TickHz(0))
    ));
    assert!(matches!(
        run(&["--tick-hz", "1001"]),
        Err(ConfigError::TickHz(1001))
    ));
    assert!(matches!(
        run(&["--tick-hz", "20", "--snapshot-hz", "30"]),
        Err(ConfigError::SnapshotHz { .. })
    ));
    assert!(matches!(
        run(&["--max-clients", "0"]),
        Err(ConfigError::MaxClients(0))
    ));
    assert!(!run(&[]).unwrap().tick_realtime, "off by default");
    let auto = run(&[]).unwrap();
    assert_eq!(auto.physics_threads, 0);
    assert!(auto.physics_threads_now() >= 1);
    assert_eq!(
        run(&["--physics-threads", "3"])
            .unwrap()
            .physics_threads_now(),
        3
    );
    assert!(matches!(
        run(&["--physics-threads", "257"]),
        Err(ConfigError::PhysicsThreads(257))
    ));
    assert_eq!(
        ServerConfig::from_args(["s"], env_of(&[("INERTIA_PHYSICS_THREADS", "1")]))
            .unwrap()
            .physics_threads,
        1
    );
    assert_eq!(auto.physics_pin_threads, PhysicsPinning::Auto);
    assert_eq!(
        run(&["--physics-pin-threads", "never"])
            .unwrap()
            .world_config()
            .pin_threads,
        inertia_physics::ThreadPinning::Never
    );
    assert_eq!(
        ServerConfig::from_args(["s"], env_of(&[("INERTIA_PHYSICS_PIN_THREADS", "always")]))
            .unwrap()
            .physics_pin_threads,
        PhysicsPinning::Always
    );
    assert!(run(&["--physics-pin-threads", "sometimes"]).is_err());
    assert!(run(&["--tick-realtime"]).unwrap().tick_realtime);
    assert!(
        ServerConfig::from_args(["s"], env_of(&[("INERTIA_TICK_REALTIME", "true")]))
            .unwrap()
            .tick_realtime
    );
    assert!(matches!(
        run(&["--retry-above-per-sec", "100001"]),
        Err(ConfigError::RetryAbove(100_001))
    ));
    assert_eq!(
        run(&["--retry-above-per-sec", "50"])
            .unwrap()
            .retry_above_per_sec,
        50
    );
    assert!(matches!(
        run(&["--max-catch-up-ticks", "0"]),
        Err(ConfigError::CatchUp(0))
    ));
    assert!(matches!(
        run(&["--cert-file", "c.pem"]),
        Err(ConfigError::CertPair)
    ));
    assert!(matches!(
        run(&["--client-budget-kbps", "0"]),
        Err(ConfigError::ClientBudget)
    ));
    assert!(matches!(run(&["--tick-hz", "x"]), Err(ConfigError::Cli(_))));
    assert!(matches!(
        run(&["--listen", "127.0.0.1:9100"]),
        Err(ConfigError::SameAddress(_))
    ));
    for bad in ["0", "1000", "NaN"] {
        assert!(matches!(
            run(&["--position-resolution-mm", bad]),
            Err(ConfigError::PositionResolution(_))
        ));
    }
    assert_eq!(
        run(&["--position-resolution-mm", "0.5"])
            .unwrap()
            .position_resolution_mm,
        0.5
    );
}

#[test]
fn recording_settings_come_from_every_layer() {
    let c = ServerConfig::from_args(["s"], env_of(&[])).unwrap();
    assert!(c.record);
    assert_eq!(c.keyframe_ticks, DEFAULT_KEYFRAME_TICKS);
    assert_eq!(c.record_max_bytes, DEFAULT_RECORD_MAX_BYTES);
    assert_eq!(
        c.recording_dir(),
        PathBuf::from("./inertia-data").join("recording")
    );
    let c = ServerConfig::from_args(
        [
            "s",
            "--record",
            "false",
            "--keyframe-ticks",
            "120",
            "--record-max-bytes",
            "10000000",
        ],
        env_of(&[]),
    )
    .unwrap();
    assert!(!c.record);
    assert_eq!(c.keyframe_ticks, 120);
    assert_eq!(c.record_max_bytes, 10_000_000);
    assert_eq!(c.recorder_config().keyframe_ticks, 120);
    assert_eq!(c.recorder_config().max_bytes, 10_000_000);
    assert_eq!(c.recorder_config().segment_bytes, 1_250_000);
    assert_eq!(
        ServerConfig::default().recorder_config().segment_bytes,
        crate::record::DEFAULT_SEGMENT_BYTES
    );
    let c =
        ServerConfig::from_args(["s", "--record"], env_of(&[("INERTIA_RECORD", "false")])).unwrap();
    assert!(
        c.record,
        "a bare --record means true and beats the environment"
    );
    let c = ServerConfig::from_args(
        ["s"],
        env_of(&[
            ("INERTIA_RECORD", "false"),
            ("INERTIA_KEYFRAME_TICKS", "30"),
            ("INERTIA_RECORD_MAX_BYTES", "2000000"),
        ]),
    )
    .unwrap();
    assert_eq!(
        (c.record, c.keyframe_ticks, c.record_max_bytes),
        (false, 30, 2_000_000)
    );
    let file = temp_file(
        "record.toml",
        "record = false\nkeyframe_ticks = 60\nrecord_max_bytes = 5000000\n",
    );
    let c =
        ServerConfig::from_args(["s", "--config", file.to_str().unwrap()], env_of(&[])).unwrap();
    assert_eq!(
        (c.record, c.keyframe_ticks, c.record_max_bytes),
        (false, 60, 5_000_000)
    );
    let e = ServerConfig::from_args(["s"], env_of(&[("INERTIA_RECORD", "maybe")])).unwrap_err();
    assert!(
        matches!(&e, ConfigError::Env { var, .. } if var == "INERTIA_RECORD"),
        "{e}"
    );
    for bad in ["0", "1000001"] {
        assert!(matches!(
            ServerConfig::from_args(["s", "--keyframe-ticks", bad], env_of(&[])),
            Err(ConfigError::KeyframeTicks(_))
        ));
    }
    assert!(matches!(
        ServerConfig::from_args(["s", "--record-max-bytes", "1000"], env_of(&[])),
        Err(ConfigError::RecordMaxBytes(1000))
    ));
    // Seeking's memory and checkpoints.
    let c = ServerConfig::from_args(
        ["s", "--seek-memory-mb", "64"],
        env_of(&[("INERTIA_CHECKPOINT_TICKS", "30")]),
    )
    .unwrap();
    assert_eq!((c.seek_memory_mb, c.checkpoint_ticks), (64, 30));
    let sim = SimConfig::from(&c);
    // A quarter of it holds the frames of players' replays.
    assert_eq!((sim.history_budget, sim.checkpoint_ticks), (48 << 20, 30));
    assert_eq!(c.replay_window_bytes(), 16 << 20);
    let no_replays = ServerConfig::from_args(
        ["s", "--seek-memory-mb", "64", "--replay-window-s", "0"],
        env_of(&[]),
    )
    .unwrap();
    assert_eq!(SimConfig::from(&no_replays).history_budget, 64 << 20);
    assert_eq!(no_replays.replays().window_s, 0);
    let c = ServerConfig::from_args(["s"], env_of(&[("INERTIA_MAX_REPLAYS", "3")])).unwrap();
    assert_eq!((c.replays().max_playing, c.replays().window_s), (3, 30));
    assert!(matches!(
        ServerConfig::from_args(["s", "--replay-window-s", "301"], env_of(&[])),
        Err(ConfigError::ReplayWindow(301))
    ));
    assert!(matches!(
        ServerConfig::from_args(["s", "--max-replays", "257"], env_of(&[])),
        Err(ConfigError::MaxReplays(257))
    ));
    assert!(matches!(
        ServerConfig::from_args(["s", "--seek-memory-mb", "1"], env_of(&[])),
        Err(ConfigError::SeekMemory(1))
    ));
    assert!(matches!(
        ServerConfig::from_args(["s", "--checkpoint-ticks", "2000000"], env_of(&[])),
        Err(ConfigError::CheckpointTicks(2_000_000))
    ));
}

#[test]
fn issue_11_checkpoint_dir_comes_from_every_layer() {
    let c = ServerConfig::from_args(["s", "--data-dir", "/srv/inertia"], env_of(&[])).unwrap();
    assert_eq!(c.checkpoint_dir, None);
    assert_eq!(
        c.checkpoint_dir(),
        PathBuf::from("/srv/inertia/checkpoints"),
        "under the data directory by default"
    );
    let file = temp_file("checkpoints.toml", "checkpoint_dir = \"/from/file\"\n");
    let file = file.to_str().unwrap();
    let c = ServerConfig::from_args(["s", "--config", file], env_of(&[])).unwrap();
    assert_eq!(c.checkpoint_dir(), PathBuf::from("/from/file"));
    let env = || env_of(&[("INERTIA_CHECKPOINT_DIR", "/from/env")]);
    let c = ServerConfig::from_args(["s", "--config", file], env()).unwrap();
    assert_eq!(c.checkpoint_dir(), PathBuf::from("/from/env"));
    let c = ServerConfig::from_args(
        ["s", "--config", file, "--checkpoint-dir", "/from/cli"],
        env(),
    )
    .unwrap();
    assert_eq!(c.checkpoint_dir(), PathBuf::from("/from/cli"));
}

#[test]
fn issue_11_admin_token_file_comes_from_every_layer() {
    let c = ServerConfig::from_args(["s"], env_of(&[])).unwrap();
    assert_eq!(c.admin_token_file, None);
    let file = temp_file("admin.toml", "admin_token_file = \"/from/file\"\n");
    let file = file.to_str().unwrap();
    let c = ServerConfig::from_args(["s", "--config", file], env_of(&[])).unwrap();
    assert_eq!(c.admin_token_file, Some(PathBuf::from("/from/file")));
    let env = || env_of(&[("INERTIA_ADMIN_TOKEN_FILE", "/from/env")]);
    let c = ServerConfig::from_args(["s", "--config", file], env()).unwrap();
    assert_eq!(c.admin_token_file, Some(PathBuf::from("/from/env")));
    let c = ServerConfig::from_args(
        ["s", "--config", file, "--admin-token-file", "/from/cli"],
        env(),
    )
    .unwrap();
    assert_eq!(c.admin_token_file, Some(PathBuf::from("/from/cli")));
}

#[test]
fn missing_file_is_an_io_error() {
    let e = ServerConfig::from_args(["s", "--config", "/no/such/inertia.toml"], env_of(&[]))
        .unwrap_err();
    assert!(matches!(e, ConfigError::Io { .. }), "{e}");
}
