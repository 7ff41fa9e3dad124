//! Who may use the admin channel: the operators of the admin token file
//! (`--admin-token-file`), each with their own token, and in dev mode the
//! token of the dev credentials file.
//!
//! # The file
//!
//! One operator a line, their name and their token separated by spaces
//! or tabs:
//!
//! ```text
//! # operators of the eu-west fleet
//! alice   3q2+7w8yKx0m1Zp4VbT6nR9sLcJ5aH0dEeFgUiOo
//! bob     0f8e6c1d2b3a49587a6b5c4d3e2f1a0b9c8d7e6f
//! ```
//!
//! Blank lines and lines whose first character (after spaces) is `#` are
//! skipped. A name follows the admin protocol's rule for operator names
//! ([`check_operator_name`]: at most 64 bytes of UTF-8, no control
//! characters) and cannot hold spaces; a name appears once. A token is at
//! least [`MIN_TOKEN_CHARS`] characters and at most
//! [`MAX_CREDENTIAL_BYTES`] bytes, without spaces. A file whose one entry
//! is a token alone (the format before named operators) admits that token
//! under any operator name. A file with no entries admits no one. A line
//! that is wrong refuses the whole file with a [`TokenFileError`] naming
//! the file and the line, never what the line holds.
//!
//! The file should be readable by the server's user alone (mode 0600): a
//! file that its group or others may read or write is loaded all the
//! same, with a warning in the log.
//!
//! # Checking a hello
//!
//! Tokens are held as SHA-256 digests, never as text. [`AdminTokens::admit`]
//! hashes the hello's operator name and token once, then compares both
//! digests with every entry's, each in constant time
//! ([`subtle::ConstantTimeEq`]): the work is the same
//! whichever name is asked for, known or not, and whatever the token, so
//! the time a refusal takes tells neither names nor tokens.
//!
//! # Reloading
//!
//! [`AdminTokenStore::reload`] (what the server process runs on SIGHUP)
//! reads the file again: a good file replaces the whole set at once; a bad
//! one is logged and the set in use stays. Admitted sessions are not
//! touched; the next hello meets the new set.

use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::{Arc, RwLock};

use inertia_protocol::admin::{check_operator_name, AdminValidationError, MAX_CREDENTIAL_BYTES};
use subtle::{Choice, ConstantTimeEq};
use tracing::{error, info, warn};

use crate::metrics::Metrics;

/// Fewest characters in an admin token.
pub const MIN_TOKEN_CHARS: usize = 32;
/// Most entries in an admin token file.
pub const MAX_OPERATORS: usize = 1024;
/// Largest admin token file, bytes.
pub const MAX_TOKEN_FILE_BYTES: u64 = 1 << 20;

/// The audit log's target.
const AUDIT: &str = "inertia::admin";

type Digest = [u8; 32];

fn sha256(bytes: &[u8]) -> Digest {
    let digest = ring::digest::digest(&ring::digest::SHA256, bytes);
    let mut out = [0u8; 32];
    out.copy_from_slice(digest.as_ref());
    out
}

/// One credential.
#[derive(Clone)]
struct Entry {
    /// The operator it admits; `None` admits any name (the dev token, or
    /// a file's lone token).
    name: Option<String>,
    /// SHA-256 of the name (of nothing when `name` is `None`).
    name_digest: Digest,
    /// SHA-256 of the token.
    token_digest: Digest,
}

impl Entry {
    fn new(name: Option<&str>, token: &str) -> Entry {
        Entry {
            name: name.map(str::to_string),
            name_digest: sha256(name.unwrap_or("").as_bytes()),
            token_digest: sha256(token.as_bytes()),
        }
    }
}

/// Who an admitted hello is, for the audit log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Admitted {
    /// The operator's name (the hello's name, which for a named entry is
    /// the name in the file).
    pub operator: String,
    /// True when a token that admits any name admitted it (the dev token,
    /// or a file's lone token): the name is then only what the tool said.
    pub shared: bool,
}

/// A set of admin credentials (see the module docs).
#[derive(Clone, Default)]
pub struct AdminTokens {
    entries: Vec<Entry>,
}

impl std::fmt::Debug for AdminTokens {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AdminTokens")
            .field("operators", &self.operators().collect::<Vec<_>>())
            .field("shared", &self.entries.iter().any(|e| e.name.is_none()))
            .finish()
    }
}

/// What is wrong with one line of an admin token file. None of them holds
/// any part of the line: it may be a token.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LineProblem {
    /// Not `NAME TOKEN` (nor a lone token).
    #[error("expected `OPERATOR TOKEN`, found {0} fields")]
    Fields(usize),
    /// The operator name breaks the protocol's rule.
    #[error("{0}")]
    Name(AdminValidationError),
    /// The token is too short.
    #[error("the token is shorter than {MIN_TOKEN_CHARS} characters")]
    ShortToken,
    /// The token is longer than a hello may carry.
    #[error("the token is longer than {MAX_CREDENTIAL_BYTES} bytes")]
    LongToken,
    /// The operator was named on an earlier line.
    #[error("this operator is already named on line {first}")]
    Duplicate {
        /// The earlier line.
        first: usize,
    },
    /// A token without a name beside other entries.
    #[error("a token without an operator name must be the file's only entry")]
    LoneTokenNotAlone,
    /// One entry too many.
    #[error("more than {MAX_OPERATORS} entries")]
    TooMany,
}

/// Why an admin token file was refused.
#[derive(Debug, thiserror::Error)]
pub enum TokenFileError {
    /// No admin token file is configured (nothing to reload).
    #[error("no admin token file is configured (--admin-token-file)")]
    NotConfigured,
    /// The file could not be read.
    #[error("admin token file {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The path names a directory, a FIFO or a device.
    #[error("admin token file {}: not a regular file", path.display())]
    NotAFile {
        /// The file.
        path: PathBuf,
    },
    /// The file is larger than [`MAX_TOKEN_FILE_BYTES`].
    #[error("admin token file {}: larger than {MAX_TOKEN_FILE_BYTES} bytes", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
    },
    /// The file is not UTF-8.
    #[error("admin token file {}: not UTF-8 text", path.display())]
    NotText {
        /// The file.
        path: PathBuf,
    },
    /// A line is wrong.
    #[error("admin token file {}, line {line}: {problem}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// The line, from 1.
        line: usize,
        /// What is wrong with it.
        problem: LineProblem,
    },
}

impl AdminTokens {
    /// A set that admits no one.
    pub fn none() -> AdminTokens {
        AdminTokens::default()
    }

    /// A set of one token that admits any operator name (the dev token).
    pub fn shared(token: &str) -> AdminTokens {
        AdminTokens {
            entries: vec![Entry::new(None, token)],
        }
    }

    /// The same set, also admitting `token` under any operator name.
    pub fn with_shared(mut self, token: &str) -> AdminTokens {
        self.entries.push(Entry::new(None, token));
        self
    }

    /// Parses the text of an admin token file (`path` names it in errors).
    pub fn parse(path: &Path, text: &str) -> Result<AdminTokens, TokenFileError> {
        let bad = |line: usize, problem: LineProblem| TokenFileError::Line {
            path: path.to_path_buf(),
            line,
            problem,
        };
        let mut entries = Vec::new();
        let mut named: HashMap<&str, usize> = HashMap::new();
        let mut lone: Option<usize> = None;
        for (i, line) in text.lines().enumerate() {
            let number = i + 1;
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            if entries.len() == MAX_OPERATORS {
                return Err(bad(number, LineProblem::TooMany));
            }
            let mut fields = line.split_whitespace();
            let (name, token) = match (fields.next(), fields.next(), fields.next()) {
                (Some(token), None, _) => (None, token),
                (Some(name), Some(token), None) => (Some(name), token),
                _ => return Err(bad(number, LineProblem::Fields(3 + fields.count()))),
            };
            if let Some(name) = name {
                check_operator_name(name).map_err(|e| bad(number, LineProblem::Name(e)))?;
            }
            if token.chars().count() < MIN_TOKEN_CHARS {
                return Err(bad(number, LineProblem::ShortToken));
            }
            if token.len() > MAX_CREDENTIAL_BYTES {
                return Err(bad(number, LineProblem::LongToken));
            }
            match name {
                Some(name) => {
                    if let Some(&first) = named.get(name) {
                        return Err(bad(number, LineProblem::Duplicate { first }));
                    }
                    named.insert(name, number);
                }
                None => lone = lone.or(Some(number)),
            }
            if lone.is_some() && !entries.is_empty() {
                return Err(bad(number, LineProblem::LoneTokenNotAlone));
            }
            entries.push(Entry::new(name, token));
        }
        Ok(AdminTokens { entries })
    }

    /// Reads and parses the admin token file at `path`, warning in the log
    /// when its group or others may read or write it.
    pub fn load(path: &Path) -> Result<AdminTokens, TokenFileError> {
        let io = |source| TokenFileError::Io {
            path: path.to_path_buf(),
            source,
        };
        // Checked before opening, so a FIFO is never opened (which would
        // wait for a writer).
        let meta = std::fs::metadata(path).map_err(io)?;
        if !meta.is_file() {
            return Err(TokenFileError::NotAFile {
                path: path.to_path_buf(),
            });
        }
        if let Some(mode) = open_to_others(&meta) {
            warn!(
                target: AUDIT,
                path = %path.display(),
                mode = format!("{mode:04o}"),
                "the admin token file is open to its group or others; make it mode 0600"
            );
        }
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .map_err(io)?
            .take(MAX_TOKEN_FILE_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(io)?;
        if bytes.len() as u64 > MAX_TOKEN_FILE_BYTES {
            return Err(TokenFileError::TooLarge {
                path: path.to_path_buf(),
            });
        }
        let text = String::from_utf8(bytes).map_err(|_| TokenFileError::NotText {
            path: path.to_path_buf(),
        })?;
        AdminTokens::parse(path, &text)
    }

    /// The entry that admits a hello from `operator` with `token`, if any
    /// (see the module docs for why this takes the same time whatever it
    /// finds).
    pub fn admit(&self, operator: &str, token: &str) -> Option<Admitted> {
        let name = sha256(operator.as_bytes());
        let given = sha256(token.as_bytes());
        let mut found: Option<&Entry> = None;
        for entry in &self.entries {
            let any_name = Choice::from(u8::from(entry.name.is_none()));
            let name_ok = entry.name_digest[..].ct_eq(&name[..]) | any_name;
            let token_ok = entry.token_digest[..].ct_eq(&given[..]);
            // Every entry is compared whole, whatever matched before.
            if bool::from(name_ok & token_ok) && found.is_none() {
                found = Some(entry);
            }
        }
        found.map(|entry| Admitted {
            operator: entry.name.clone().unwrap_or_else(|| operator.to_string()),
            shared: entry.name.is_none(),
        })
    }

    /// The named operators, in file order.
    pub fn operators(&self) -> impl Iterator<Item = &str> {
        self.entries.iter().filter_map(|e| e.name.as_deref())
    }

    /// How many credentials (named operators and shared tokens).
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when the set admits no one.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// The permission bits of a file its group or others may read or write
/// (`None` when only its owner may, and off Unix).
pub fn open_to_others(meta: &std::fs::Metadata) -> Option<u32> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = meta.permissions().mode() & 0o7777;
        (mode & 0o066 != 0).then_some(mode)
    }
    #[cfg(not(unix))]
    {
        let _ = meta;
        None
    }
}

/// The server's admin credentials in use: the set from the admin token
/// file (reloadable) and the dev token, if any, which every set admits
/// beside the file's.
pub struct AdminTokenStore {
    file: Option<PathBuf>,
    dev_token: Option<String>,
    current: RwLock<Arc<AdminTokens>>,
    metrics: Metrics,
}

impl std::fmt::Debug for AdminTokenStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AdminTokenStore")
            .field("file", &self.file)
            .field("dev_token", &self.dev_token.is_some())
            .field("current", &self.current())
            .finish()
    }
}

impl AdminTokenStore {
    /// A store that admits no one (and has nothing to reload).
    pub fn none(metrics: Metrics) -> AdminTokenStore {
        AdminTokenStore {
            file: None,
            dev_token: None,
            current: RwLock::new(Arc::new(AdminTokens::none())),
            metrics,
        }
    }

    /// The store of a server: the operators of `file` (read now; a bad
    /// file is an error), and `dev_token` under any name. Neither: the
    /// admin channel admits no one.
    pub fn open(
        file: Option<PathBuf>,
        dev_token: Option<String>,
        metrics: Metrics,
    ) -> Result<AdminTokenStore, TokenFileError> {
        let store = AdminTokenStore {
            file,
            dev_token,
            current: RwLock::new(Arc::new(AdminTokens::none())),
            metrics,
        };
        let tokens = store.read()?;
        if let Some(path) = &store.file {
            info!(
                target: AUDIT,
                path = %path.display(),
                operators = tokens.operators().count(),
                entries = tokens.len(),
                "admin token file loaded"
            );
        }
        store.install(tokens);
        Ok(store)
    }

    /// The file's set with the dev token added.
    fn read(&self) -> Result<AdminTokens, TokenFileError> {
        let tokens = match &self.file {
            Some(path) => AdminTokens::load(path)?,
            None => AdminTokens::none(),
        };
        Ok(match &self.dev_token {
            Some(dev) => tokens.with_shared(dev),
            None => tokens,
        })
    }

    fn install(&self, tokens: AdminTokens) {
        self.metrics.admin_operators.set(tokens.len() as i64);
        let mut current = self.current.write().unwrap_or_else(|e| e.into_inner());
        *current = Arc::new(tokens);
    }

    /// The set in use now.
    pub fn current(&self) -> Arc<AdminTokens> {
        self.current
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// The admin token file, if one is configured.
    pub fn file(&self) -> Option<&Path> {
        self.file.as_deref()
    }

    /// Reads the admin token file again. A good file replaces the set in
    /// use, all at once, and the number of entries is returned; a bad one
    /// leaves the set as it was. Either way the outcome is logged (target
    /// `inertia::admin`) and counted in `inertia_admin_token_reloads_total`.
    /// Blocking (it reads a file).
    pub fn reload(&self) -> Result<usize, TokenFileError> {
        let Some(path) = &self.file else {
            warn!(target: AUDIT, "asked to reload the admin token file, but none is configured");
            self.metrics.admin_token_reload("error");
            return Err(TokenFileError::NotConfigured);
        };
        match self.read() {
            Ok(tokens) => {
                let entries = tokens.len();
                info!(
                    target: AUDIT,
                    path = %path.display(),
                    operators = tokens.operators().count(),
                    entries,
                    outcome = "ok",
                    "admin token file reloaded"
                );
                self.install(tokens);
                self.metrics.admin_token_reload("ok");
                Ok(entries)
            }
            Err(e) => {
                error!(
                    target: AUDIT,
                    error = %e,
                    outcome = "error",
                    "admin token file not reloaded; the operators loaded before stay"
                );
                self.metrics.admin_token_reload("error");
                Err(e)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALICE: &str = "alice-token-0123456789abcdefghijklmnop";
    const BOB: &str = "bob-token-0123456789abcdefghijklmnopqrs";

    fn parse(text: &str) -> Result<AdminTokens, TokenFileError> {
        AdminTokens::parse(Path::new("/etc/inertia/admin-tokens"), text)
    }

    fn line_error(text: &str) -> (usize, LineProblem, String) {
        match parse(text) {
            Err(e @ TokenFileError::Line { .. }) => {
                let shown = e.to_string();
                let TokenFileError::Line { line, problem, .. } = e else {
                    unreachable!()
                };
                (line, problem, shown)
            }
            other => panic!("{text:?}: expected a line error, got {other:?}"),
        }
    }

    #[test]
    fn issue_11_each_operator_is_admitted_with_their_own_token_only() {
        let tokens = parse(&format!(
            "# the fleet's operators\n\n  alice {ALICE}\n\tbob\t\t{BOB}  \r\n# end\n"
        ))
        .unwrap();
        assert_eq!(tokens.operators().collect::<Vec<_>>(), ["alice", "bob"]);
        assert_eq!(
            tokens.admit("alice", ALICE),
            Some(Admitted {
                operator: "alice".into(),
                shared: false
            })
        );
        assert_eq!(tokens.admit("bob", BOB).unwrap().operator, "bob");
        // Another operator's token, an unknown name, a near miss, nothing.
        assert_eq!(tokens.admit("alice", BOB), None);
        assert_eq!(tokens.admit("bob", ALICE), None);
        assert_eq!(tokens.admit("carol", ALICE), None);
        assert_eq!(tokens.admit("Alice", ALICE), None);
        assert_eq!(tokens.admit("alice", &ALICE[..ALICE.len() - 1]), None);
        assert_eq!(tokens.admit("alice", &format!("{ALICE}x")), None);
        assert_eq!(tokens.admit("", ""), None);
        // Debug shows names, never tokens.
        let shown = format!("{tokens:?}");
        assert!(shown.contains("alice") && !shown.contains(ALICE), "{shown}");
        // No entries: no one.
        let empty = parse("# nobody yet\n\n").unwrap();
        assert!(empty.is_empty());
        assert_eq!(empty.admit("alice", ALICE), None);
        assert_eq!(AdminTokens::none().admit("", ""), None);
    }

    #[test]
    fn issue_11_a_lone_token_admits_any_operator_name() {
        let tokens = parse(&format!("\n{ALICE}\n")).unwrap();
        assert_eq!(tokens.operators().count(), 0);
        assert_eq!(
            tokens.admit("whoever", ALICE),
            Some(Admitted {
                operator: "whoever".into(),
                shared: true
            })
        );
        assert_eq!(tokens.admit("whoever", BOB), None);
        // The dev token beside named operators.
        let tokens = parse(&format!("alice {ALICE}\n")).unwrap().with_shared(BOB);
        assert!(!tokens.admit("alice", ALICE).unwrap().shared);
        assert!(tokens.admit("dev", BOB).unwrap().shared);
        assert_eq!(tokens.admit("dev", ALICE), None);
        assert_eq!(
            AdminTokens::shared(BOB).admit("x", BOB).unwrap().operator,
            "x"
        );
    }

    #[test]
    fn issue_11_token_file_errors_name_the_line_and_never_the_token() {
        let cases: Vec<(String, usize, LineProblem)> = vec![
            (
                format!("# ok\nalice {ALICE}\nbob {BOB} extra\n"),
                3,
                LineProblem::Fields(3),
            ),
            (
                format!("alice {ALICE}\nbob short-token\n"),
                2,
                LineProblem::ShortToken,
            ),
            (
                format!(
                    "alice {ALICE}\nbob {}\n",
                    "t".repeat(MAX_CREDENTIAL_BYTES + 1)
                ),
                2,
                LineProblem::LongToken,
            ),
            (
                format!("alice {ALICE}\n\n# again\nalice {BOB}\n"),
                4,
                LineProblem::Duplicate { first: 1 },
            ),
            (
                format!("alice {ALICE}\n{BOB}\n"),
                2,
                LineProblem::LoneTokenNotAlone,
            ),
            (
                format!("{BOB}\nalice {ALICE}\n"),
                2,
                LineProblem::LoneTokenNotAlone,
            ),
            (
                format!("{}-{ALICE} {BOB}\n", "o".repeat(64)),
                1,
                LineProblem::Name(AdminValidationError::TooLong {
                    what: "operator name",
                    len: 64 + 1 + ALICE.len(),
                    max: 64,
                }),
            ),
            (
                format!("al\u{7}ice {ALICE}\n"),
                1,
                LineProblem::Name(AdminValidationError::ControlCharacter),
            ),
        ];
        for (text, line, problem) in cases {
            let (got_line, got, shown) = line_error(&text);
            assert_eq!((got_line, &got), (line, &problem), "{text:?}");
            assert!(shown.contains("/etc/inertia/admin-tokens"), "{shown}");
            assert!(shown.contains(&format!("line {line}")), "{shown}");
            for secret in [ALICE, BOB, "short-token", "alice", "bob"] {
                assert!(!shown.contains(secret), "{shown} shows {secret:?}");
            }
        }
        // Too many entries.
        let many: String = (0..=MAX_OPERATORS)
            .map(|i| format!("op{i} {ALICE}\n"))
            .collect();
        let (line, problem, _) = line_error(&many);
        assert_eq!((line, problem), (MAX_OPERATORS + 1, LineProblem::TooMany));
    }

    fn temp_file(name: &str, text: &str, mode: u32) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("inertia-tokens-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode)).unwrap();
        }
        #[cfg(not(unix))]
        let _ = mode;
        path
    }

    #[test]
    fn issue_11_token_files_are_read_bounded_and_checked_for_their_mode() {
        let path = temp_file("private", &format!("alice {ALICE}\n"), 0o600);
        assert!(open_to_others(&std::fs::metadata(&path).unwrap()).is_none());
        assert_eq!(AdminTokens::load(&path).unwrap().len(), 1);
        // Readable by others: loaded, and flagged (the load warns).
        let open = temp_file("open", &format!("alice {ALICE}\n"), 0o644);
        #[cfg(unix)]
        assert_eq!(
            open_to_others(&std::fs::metadata(&open).unwrap()),
            Some(0o644)
        );
        assert_eq!(AdminTokens::load(&open).unwrap().len(), 1);
        let dir = path.parent().unwrap();
        assert!(matches!(
            AdminTokens::load(dir),
            Err(TokenFileError::NotAFile { .. })
        ));
        assert!(matches!(
            AdminTokens::load(&dir.join("missing")),
            Err(TokenFileError::Io { .. })
        ));
        let big = temp_file("big", &"#".repeat(MAX_TOKEN_FILE_BYTES as usize + 1), 0o600);
        assert!(matches!(
            AdminTokens::load(&big),
            Err(TokenFileError::TooLarge { .. })
        ));
        std::fs::write(&big, [0xff, 0xfe, b'\n']).unwrap();
        assert!(matches!(
            AdminTokens::load(&big),
            Err(TokenFileError::NotText { .. })
        ));
    }

    #[test]
    fn issue_11_reload_replaces_the_set_and_a_bad_file_keeps_the_old_one() {
        let path = temp_file("reload", &format!("alice {ALICE}\n"), 0o600);
        let metrics = Metrics::new();
        let store = AdminTokenStore::open(Some(path.clone()), None, metrics.clone()).unwrap();
        let before = store.current();
        assert!(before.admit("alice", ALICE).is_some());
        assert_eq!(metrics.admin_operators.get(), 1);

        std::fs::write(&path, format!("bob {BOB}\ncarol {ALICE}xyz\n")).unwrap();
        assert_eq!(store.reload().unwrap(), 2);
        let now = store.current();
        assert!(now.admit("alice", ALICE).is_none(), "alice is gone");
        assert!(now.admit("bob", BOB).is_some());
        assert!(now.admit("carol", &format!("{ALICE}xyz")).is_some());
        // A set taken before the reload is not changed under its holder.
        assert!(before.admit("alice", ALICE).is_some());
        assert_eq!(metrics.admin_token_reload_count("ok"), 1);
        assert_eq!(metrics.admin_operators.get(), 2);

        // A bad file: an error naming the line, the set in use stays.
        std::fs::write(&path, format!("bob {BOB}\nbob {ALICE}\n")).unwrap();
        let e = store.reload().unwrap_err();
        assert!(
            matches!(
                e,
                TokenFileError::Line {
                    line: 2,
                    problem: LineProblem::Duplicate { first: 1 },
                    ..
                }
            ),
            "{e}"
        );
        assert!(store.current().admit("bob", BOB).is_some());
        assert!(store
            .current()
            .admit("carol", &format!("{ALICE}xyz"))
            .is_some());
        std::fs::remove_file(&path).unwrap();
        assert!(matches!(store.reload(), Err(TokenFileError::Io { .. })));
        assert!(store.current().admit("bob", BOB).is_some());
        assert_eq!(metrics.admin_token_reload_count("error"), 2);
        assert_eq!(metrics.admin_operators.get(), 2);

        // The dev token survives every reload; without a file there is
        // nothing to reload.
        std::fs::write(&path, format!("alice {ALICE}\n")).unwrap();
        let store =
            AdminTokenStore::open(Some(path.clone()), Some(BOB.into()), Metrics::new()).unwrap();
        assert!(store.current().admit("dev", BOB).is_some());
        std::fs::write(&path, "").unwrap();
        assert_eq!(store.reload().unwrap(), 1);
        assert!(store.current().admit("alice", ALICE).is_none());
        assert!(store.current().admit("dev", BOB).is_some());
        let store = AdminTokenStore::open(None, None, Metrics::new()).unwrap();
        assert!(store.current().is_empty());
        assert!(matches!(store.reload(), Err(TokenFileError::NotConfigured)));
        // A bad file at start is an error.
        std::fs::write(&path, "alice short\n").unwrap();
        assert!(AdminTokenStore::open(Some(path.clone()), None, Metrics::new()).is_err());
    }
}
