//! Records the flags the bench is compiled with, so every `physics` record
//! can say whether it came from a `-C target-cpu=native` build.

fn main() {
    println!("cargo:rerun-if-env-changed=CARGO_ENCODED_RUSTFLAGS");
    let flags = std::env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
    let flags = flags.split('\x1f').collect::<Vec<_>>().join(" ");
    println!("cargo:rustc-env=INERTIA_BENCH_RUSTFLAGS={flags}");
}
