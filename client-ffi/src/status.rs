//! What every call returns, the message behind a failure, and the guard
//! that keeps panics on this side of the boundary.

use std::cell::RefCell;
use std::ffi::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The outcome of a call. Anything but `INERTIA_STATUS_OK` leaves a
/// message for [`inertia_last_error`] on the calling thread.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InertiaStatus {
    /// Done.
    Ok = 0,
    /// A pointer that must not be null was, or a string was not UTF-8, or
    /// a value was out of range.
    InvalidArgument = 1,
    /// The connection could not be made, or the server refused it.
    ConnectFailed = 2,
    /// The connection has ended (the client handle is still to be freed
    /// with `inertia_disconnect`).
    Disconnected = 3,
    /// The caller's buffer was too small: what fitted was written, and the
    /// count says how many there are.
    BufferTooSmall = 4,
    /// No such entity (or not of the kind asked for).
    NotFound = 5,
    /// The library failed inside (a bug): the handle may be used again,
    /// but report it with the message.
    Internal = 6,
}

/// Why a call failed, before it is turned into a status and a message.
#[derive(Debug)]
pub(crate) struct Failure {
    pub status: InertiaStatus,
    pub message: String,
}

impl Failure {
    pub fn new(status: InertiaStatus, message: impl Into<String>) -> Self {
        Self {
            status,
            message: message.into(),
        }
    }

    pub fn invalid(message: impl Into<String>) -> Self {
        Self::new(InertiaStatus::InvalidArgument, message)
    }
}

thread_local! {
    static LAST_ERROR: RefCell<String> = const { RefCell::new(String::new()) };
}

fn set_last_error(message: String) {
    LAST_ERROR.with(|e| *e.borrow_mut() = message);
}

/// Runs a call's body: its failure becomes a status and this thread's last
/// error; a panic inside becomes `INERTIA_STATUS_INTERNAL` and never
/// crosses into the caller.
pub(crate) fn guard(body: impl FnOnce() -> Result<(), Failure>) -> InertiaStatus {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => InertiaStatus::Ok,
        Ok(Err(f)) => {
            set_last_error(f.message);
            f.status
        }
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown".into());
            set_last_error(format!("internal error (a bug): {what}"));
            InertiaStatus::Internal
        }
    }
}

/// Copies the message of the last failed call on this thread into `buf`
/// (at most `len` bytes, NUL-terminated, cut at a character boundary) and
/// returns its whole length in bytes without the NUL, so a caller can size
/// its buffer; 0 when no call failed yet. `buf` may be null when `len` is 0.
///
/// Thread-safe: each thread has its own last error.
///
/// # Safety
/// `buf` is null, or valid for writes of `len` bytes.
#[no_mangle]
pub unsafe extern "C" fn inertia_last_error(buf: *mut c_char, len: usize) -> usize {
    let result = catch_unwind(|| {
        LAST_ERROR.with(|e| {
            let message = e.borrow();
            if !buf.is_null() && len > 0 {
                let mut n = message.len().min(len - 1);
                while !message.is_char_boundary(n) {
                    n -= 1;
                }
                // SAFETY: the caller gives `len` writable bytes at `buf`.
                unsafe {
                    std::ptr::copy_nonoverlapping(message.as_ptr(), buf.cast::<u8>(), n);
                    *buf.add(n) = 0;
                }
            }
            message.len()
        })
    });
    result.unwrap_or(0)
}

/// Writes `text` into a fixed C string field (NUL-terminated, cut at a
/// character boundary).
pub(crate) fn write_c_string(field: &mut [c_char], text: &str) {
    let mut n = text.len().min(field.len().saturating_sub(1));
    while !text.is_char_boundary(n) {
        n -= 1;
    }
    for (dst, &b) in field.iter_mut().zip(&text.as_bytes()[..n]) {
        *dst = b as c_char;
    }
    if let Some(end) = field.get_mut(n) {
        *end = 0;
    }
}
