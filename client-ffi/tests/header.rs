//! `include/inertia.h` is what cbindgen makes from the crate today: a
//! change to the ABI that forgot the header fails here. Rewrite it with
//! `INERTIA_WRITE_HEADER=1 cargo test -p inertia-client-ffi --test header`.

use std::path::Path;

#[test]
fn the_committed_header_is_what_cbindgen_makes() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config =
        cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_crate(crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen reads the crate");
    let mut made = Vec::new();
    bindings.write(&mut made);
    let made = String::from_utf8(made).expect("UTF-8");
    let path = crate_dir.join("include/inertia.h");
    if std::env::var_os("INERTIA_WRITE_HEADER").is_some() {
        std::fs::write(&path, &made).expect("write the header");
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == made,
        "include/inertia.h is out of date: run INERTIA_WRITE_HEADER=1 cargo test -p inertia-client-ffi --test header"
    );
    for name in [
        "inertia_abi_version",
        "inertia_connect",
        "inertia_sample",
        "inertia_point_set",
        "INERTIA_STATUS_OK",
    ] {
        assert!(made.contains(name), "{name} is in the header");
    }
}
