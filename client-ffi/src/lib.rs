//! The Inertia client SDK behind a C ABI: `libinertia` (`.so`, `.dll`,
//! `.dylib`, and a static library), declared in `include/inertia.h`.
//!
//! Every function is prefixed `inertia_` and returns an
//! [`InertiaStatus`](status::InertiaStatus) (or a plain value where it
//! cannot fail); a failure leaves a message for `inertia_last_error` on
//! the calling thread. No Rust panic crosses the boundary: one is caught
//! and returned as `INERTIA_STATUS_INTERNAL`. The connection runs on a
//! runtime thread the handle owns, so the API is poll-based: connect,
//! then each frame poll events, sample the picture into the caller's
//! buffer, set the input; read statistics when wanted; disconnect.
//!
//! Ownership: the handle from `inertia_connect` belongs to the caller
//! until `inertia_disconnect` frees it; every buffer is the caller's, and
//! the library writes into it only during the call. Thread-safety: one
//! handle is used by one thread at a time; separate handles, and
//! `inertia_abi_version` and `inertia_last_error`, from any thread.
//!
//! The header is made by cbindgen from this crate and kept in the
//! repository; `tests/header.rs` fails when it is out of date
//! (`INERTIA_WRITE_HEADER=1` rewrites it). `examples/c` and
//! `examples/csharp` are samples that CI builds and runs against a server.

pub mod client;
pub mod status;
pub mod types;

/// The version of this ABI: the layout of its structs and the meaning of
/// its calls. It changes whenever either does; a binding checks it once
/// against the one it was written for.
pub const INERTIA_ABI_VERSION: u32 = 5;

/// The ABI version of the library loaded ([`INERTIA_ABI_VERSION`]).
#[no_mangle]
pub extern "C" fn inertia_abi_version() -> u32 {
    INERTIA_ABI_VERSION
}
