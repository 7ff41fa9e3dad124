//! The admin hello and its answer: the version, the bounds, the credential
//! compared in constant time.

use super::*;

/// The first message on an admin stream, from the operator's tool.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AdminHello {
    /// The tool's [`ADMIN_PROTOCOL_VERSION`].
    pub version: u16,
    /// The admin credential (at most [`MAX_CREDENTIAL_BYTES`]).
    pub token: String,
    /// Who is acting, for the audit log (at most [`MAX_OPERATOR_BYTES`], no
    /// control characters).
    pub operator: String,
}

/// The server's answer to an [`AdminHello`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum AdminHandshake {
    /// The hello was accepted; calls may follow.
    Welcome(AdminWelcome),
    /// The hello was refused; the server closes the connection next.
    Refused(AdminRefusal),
}

/// What the server tells an admitted operator about itself.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AdminWelcome {
    /// The server's [`ADMIN_PROTOCOL_VERSION`].
    pub version: u16,
    /// The server build, for logs (at most [`MAX_VERSION_BYTES`]).
    pub server_version: String,
    /// Physics ticks per second of simulation time, Hz (not zero).
    pub tick_hz: u32,
}

/// Why an [`AdminHello`] was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AdminRefusal {
    /// Tool and server speak different admin protocol versions.
    VersionMismatch {
        /// The server's version.
        server: u16,
        /// The tool's version.
        client: u16,
    },
    /// The credential is not the server's admin credential (or the server
    /// has none).
    BadCredential,
    /// The first message was not a well-formed hello.
    Malformed,
    /// Too many hellos from this address had a wrong credential lately;
    /// the server answers none from it until the back-off has passed.
    Throttled {
        /// How long until the server reads a hello from this address
        /// again, ms.
        retry_after_ms: u32,
    },
}

/// Checks an operator name: at most [`MAX_OPERATOR_BYTES`] of UTF-8, no
/// control characters (the name goes to the audit log as is). The rule
/// of [`AdminHello::check`], for anything else that names operators.
pub fn check_operator_name(name: &str) -> Checked {
    check_len("operator name", name.len(), MAX_OPERATOR_BYTES)?;
    if name.chars().any(char::is_control) {
        return Err(AdminValidationError::ControlCharacter);
    }
    Ok(())
}

impl AdminHello {
    /// Checks the credential's and operator name's bounds.
    pub fn check(&self) -> Checked {
        check_len("admin credential", self.token.len(), MAX_CREDENTIAL_BYTES)?;
        check_operator_name(&self.operator)
    }
}

impl AdminHandshake {
    /// Checks the welcome's bounds (a refusal has none).
    pub fn check(&self) -> Checked {
        match self {
            AdminHandshake::Welcome(w) => {
                check_len("server version", w.server_version.len(), MAX_VERSION_BYTES)?;
                if w.tick_hz == 0 {
                    return Err(AdminValidationError::OutOfRange { what: "tick rate" });
                }
                Ok(())
            }
            AdminHandshake::Refused(_) => Ok(()),
        }
    }
}

impl ControlMessage for AdminHello {
    fn validate(&self) -> Result<(), ControlError> {
        Ok(self.check()?)
    }
}

impl ControlMessage for AdminHandshake {
    fn validate(&self) -> Result<(), ControlError> {
        Ok(self.check()?)
    }
}

/// True when `given` is the admin credential `expected`, compared in time
/// that does not depend on where they differ, nor on `given`'s length:
/// both are reduced to HMAC-SHA256 tags first and the tags compared in
/// constant time. An empty `expected` matches nothing, so a server without
/// a credential admits no one.
pub fn credential_matches(expected: &str, given: &str) -> bool {
    if expected.is_empty() {
        return false;
    }
    // The key only makes both sides fixed-length; it is not a secret.
    let key = hmac::Key::new(hmac::HMAC_SHA256, b"inertia admin credential");
    let tag = hmac::sign(&key, expected.as_bytes());
    hmac::verify(&key, given.as_bytes(), tag.as_ref()).is_ok()
}

/// Answers an admin tool's first message against one credential, without
/// I/O: checks the protocol version first (so an old tool learns it is
/// old), then the hello's bounds, then its credential against `expected`
/// with [`credential_matches`]. On success a server sends
/// [`AdminHandshake::Welcome`] and logs `hello.operator`; on failure,
/// [`AdminHandshake::Refused`] and it closes the connection. (The
/// Inertia server checks the same things in the same order against its
/// table of operators, and throttles addresses that keep failing.)
pub fn admin_handshake(hello: &AdminHello, expected: &str) -> Result<(), AdminRefusal> {
    if hello.version != ADMIN_PROTOCOL_VERSION {
        return Err(AdminRefusal::VersionMismatch {
            server: ADMIN_PROTOCOL_VERSION,
            client: hello.version,
        });
    }
    if hello.check().is_err() {
        return Err(AdminRefusal::Malformed);
    }
    if !credential_matches(expected, &hello.token) {
        return Err(AdminRefusal::BadCredential);
    }
    Ok(())
}
