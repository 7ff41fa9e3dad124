//! The server's secrets: the key connect tokens are sealed with, the TLS
//! certificate and its private key, and in dev mode the admin credential.
//!
//! In dev mode (no key configured) the server makes all of them at start-up
//! and writes them to `<data-dir>/dev-credentials.json` with mode 0600 (see
//! [`inertia_protocol::credentials`]). Its certificate is one a browser can
//! pin by hash for WebTransport (ECDSA P-256, valid for less than 14 days);
//! the server renews it a day before it expires ([`renew_dev`]). Outside dev mode the key and the
//! certificate must be given, and the server refuses to start without
//! them; operators' admin credentials come from the admin token file
//! ([`crate::admin::tokens`]).

use std::fs;
use std::io::Write;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use inertia_protocol::control::PROTOCOL_VERSION;
use inertia_protocol::credentials::{hex32, to_hex, DevCredentials};
use inertia_protocol::token::cert_fingerprint;
use ring::rand::{SecureRandom, SystemRandom};
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};

/// The name of the dev credentials file inside the data directory.
pub const DEV_CREDENTIALS_FILE: &str = "dev-credentials.json";

/// Everything secret the server holds.
pub struct Credentials {
    /// The key connect tokens are sealed with.
    pub token_key: [u8; 32],
    /// The server certificate (DER).
    pub cert: CertificateDer<'static>,
    /// The certificate's private key.
    pub cert_key: PrivateKeyDer<'static>,
    /// SHA-256 of the certificate's DER, which clients pin.
    pub fingerprint: [u8; 32],
    /// The dev admin credential (hex), admitting any operator name; `None`
    /// outside dev mode.
    pub admin_token: Option<String>,
}

impl std::fmt::Debug for Credentials {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Credentials")
            .field("fingerprint", &to_hex(&self.fingerprint))
            .finish_non_exhaustive()
    }
}

/// Why the server's credentials could not be had.
#[derive(Debug, thiserror::Error)]
pub enum CredentialsError {
    /// Outside dev mode, some of the key, certificate and certificate key
    /// were given and some not.
    #[error(
        "missing {missing}: outside dev mode the server needs --key-file, --cert-file and \
         --cert-key-file (give none of them to run in dev mode on loopback)"
    )]
    Incomplete {
        /// The missing options, comma-separated.
        missing: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A file was read but its contents are wrong.
    #[error("{path}: {why}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// The certificate could not be generated.
    #[error("generating the dev certificate: {0}")]
    Generate(String),
}

/// Where production credentials come from.
#[derive(Debug, Clone, Default)]
pub struct CredentialFiles {
    /// The token key: 64 hex digits.
    pub key_file: Option<PathBuf>,
    /// The certificate, PEM or DER.
    pub cert_file: Option<PathBuf>,
    /// The certificate's private key, PEM (PKCS#8, PKCS#1 or SEC1) or DER
    /// (PKCS#8).
    pub cert_key_file: Option<PathBuf>,
}

impl CredentialFiles {
    /// True when none of the key, certificate and certificate key is given:
    /// the server then runs in dev mode.
    pub fn is_dev(&self) -> bool {
        self.key_file.is_none() && self.cert_file.is_none() && self.cert_key_file.is_none()
    }
}

fn random32() -> [u8; 32] {
    let mut out = [0u8; 32];
    SystemRandom::new()
        .fill(&mut out)
        .expect("the operating system's random source failed");
    out
}

/// How long a dev certificate is valid, days. A browser pins a
/// certificate by its hash (WebTransport's `serverCertificateHashes`) only
/// when it is valid for at most 14 days, and only for ECDSA keys.
pub const DEV_CERTIFICATE_DAYS: i64 = 13;

/// How long before its end a dev certificate is replaced, days.
pub const DEV_CERTIFICATE_RENEW_DAYS_BEFORE: i64 = 1;

/// The certificate's parameters for a dev server started at `now`: for
/// `localhost` and the loopback addresses, valid from an hour before `now`
/// (for clocks a little behind) for [`DEV_CERTIFICATE_DAYS`].
pub fn dev_certificate_params(now: time::OffsetDateTime) -> rcgen::CertificateParams {
    let mut params = rcgen::CertificateParams::default();
    params.subject_alt_names = vec![
        rcgen::SanType::DnsName("localhost".try_into().expect("a valid DNS name")),
        rcgen::SanType::IpAddress(std::net::Ipv4Addr::LOCALHOST.into()),
        rcgen::SanType::IpAddress(std::net::Ipv6Addr::LOCALHOST.into()),
    ];
    params
        .distinguished_name
        .push(rcgen::DnType::CommonName, "inertia dev server");
    params.not_before = now - time::Duration::hours(1);
    params.not_after = params.not_before + time::Duration::days(DEV_CERTIFICATE_DAYS);
    params
}

/// A fresh dev certificate and its key (ECDSA P-256 with SHA-256).
fn dev_certificate(
    now: time::OffsetDateTime,
) -> Result<(CertificateDer<'static>, PrivateKeyDer<'static>), CredentialsError> {
    let generate = |e: rcgen::Error| CredentialsError::Generate(e.to_string());
    let key = rcgen::KeyPair::generate_for(&rcgen::PKCS_ECDSA_P256_SHA256).map_err(generate)?;
    let cert = dev_certificate_params(now)
        .self_signed(&key)
        .map_err(generate)?;
    let cert_key = PrivateKeyDer::try_from(key.serialize_der())
        .map_err(|e| CredentialsError::Generate(e.to_string()))?;
    Ok((cert.der().clone(), cert_key))
}

/// Makes fresh dev credentials for a server at `addr` and writes them to
/// `<data_dir>/dev-credentials.json` (mode 0600, replacing any earlier
/// file). Returns the credentials and the file's path.
pub fn make_dev(
    data_dir: &Path,
    addr: SocketAddr,
) -> Result<(Credentials, PathBuf), CredentialsError> {
    let (cert, cert_key) = dev_certificate(time::OffsetDateTime::now_utc())?;
    let creds = Credentials {
        token_key: random32(),
        fingerprint: cert_fingerprint(&cert),
        cert,
        cert_key,
        admin_token: Some(to_hex(&random32())),
    };
    let path = write_dev(data_dir, addr, &creds)?;
    Ok((creds, path))
}

/// Dev credentials like `creds` with a new certificate (the token key and
/// the admin credential kept), written to the dev credentials file in
/// place of the old: clients that read the file from now on pin the new
/// certificate, and those connected keep their connections.
pub fn renew_dev(
    creds: &Credentials,
    data_dir: &Path,
    addr: SocketAddr,
) -> Result<Credentials, CredentialsError> {
    let (cert, cert_key) = dev_certificate(time::OffsetDateTime::now_utc())?;
    let renewed = Credentials {
        token_key: creds.token_key,
        fingerprint: cert_fingerprint(&cert),
        cert,
        cert_key,
        admin_token: creds.admin_token.clone(),
    };
    write_dev(data_dir, addr, &renewed)?;
    Ok(renewed)
}

/// Writes `creds` as the dev credentials file of a server at `addr`.
fn write_dev(
    data_dir: &Path,
    addr: SocketAddr,
    creds: &Credentials,
) -> Result<PathBuf, CredentialsError> {
    let file = DevCredentials {
        server_addr: addr.to_string(),
        cert_fingerprint: to_hex(&creds.fingerprint),
        token_key: to_hex(&creds.token_key),
        admin_token: creds.admin_token.clone().unwrap_or_default(),
        protocol_version: PROTOCOL_VERSION,
    };
    let path = data_dir.join(DEV_CREDENTIALS_FILE);
    let io = |source| CredentialsError::Io {
        path: path.clone(),
        source,
    };
    fs::create_dir_all(data_dir).map_err(|source| CredentialsError::Io {
        path: data_dir.to_path_buf(),
        source,
    })?;
    let json = serde_json::to_vec_pretty(&file).expect("plain strings serialise");
    write_private(&path, &json).map_err(io)?;
    Ok(path)
}

/// Writes `bytes` to `path` readable by its owner only (0600 on Unix): the
/// file is created with that mode, so no other user can open it between
/// creation and the permission change.
fn write_private(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = path.with_extension("json.tmp");
    let _ = fs::remove_file(&tmp);
    let mut options = fs::OpenOptions::new();
    options.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.mode(0o600);
    }
    let mut f = options.open(&tmp)?;
    f.write_all(bytes)?;
    f.sync_all()?;
    drop(f);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        fs::set_permissions(&tmp, fs::Permissions::from_mode(0o600))?;
    }
    fs::rename(&tmp, path)
}

/// Loads production credentials. Every one of key, certificate and
/// certificate key must be given.
pub fn load(files: &CredentialFiles) -> Result<Credentials, CredentialsError> {
    let mut missing = Vec::new();
    if files.key_file.is_none() {
        missing.push("--key-file");
    }
    if files.cert_file.is_none() {
        missing.push("--cert-file");
    }
    if files.cert_key_file.is_none() {
        missing.push("--cert-key-file");
    }
    let (Some(key_file), Some(cert_file), Some(cert_key_file)) =
        (&files.key_file, &files.cert_file, &files.cert_key_file)
    else {
        return Err(CredentialsError::Incomplete {
            missing: missing.join(", "),
        });
    };
    let read = |path: &Path| {
        fs::read(path).map_err(|source| CredentialsError::Io {
            path: path.to_path_buf(),
            source,
        })
    };
    let invalid = |path: &Path, why: String| CredentialsError::Invalid {
        path: path.to_path_buf(),
        why,
    };
    let key_text =
        String::from_utf8(read(key_file)?).map_err(|_| invalid(key_file, "not text".into()))?;
    let token_key = hex32("token key", &key_text).map_err(|e| invalid(key_file, e.to_string()))?;
    let cert_bytes = read(cert_file)?;
    let cert = if cert_bytes.starts_with(b"-----") {
        CertificateDer::from_pem_slice(&cert_bytes)
            .map_err(|e| invalid(cert_file, format!("no PEM certificate: {e}")))?
    } else {
        CertificateDer::from(cert_bytes)
    };
    let cert_key_bytes = read(cert_key_file)?;
    let cert_key = if cert_key_bytes.starts_with(b"-----") {
        PrivateKeyDer::from_pem_slice(&cert_key_bytes)
            .map_err(|e| invalid(cert_key_file, format!("no PEM private key: {e}")))?
    } else {
        PrivateKeyDer::try_from(cert_key_bytes).map_err(|e| invalid(cert_key_file, e.into()))?
    };
    Ok(Credentials {
        token_key,
        fingerprint: cert_fingerprint(&cert),
        cert,
        cert_key,
        admin_token: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("inertia-creds-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn the_dev_certificate_is_one_a_browser_pins_by_hash_and_renews_keeping_the_secrets() {
        // WebTransport's serverCertificateHashes: ECDSA, valid at most 14 days.
        let now = time::OffsetDateTime::now_utc();
        let params = dev_certificate_params(now);
        let valid = params.not_after - params.not_before;
        assert!(valid <= time::Duration::days(14), "valid for {valid}");
        assert!(valid >= time::Duration::days(DEV_CERTIFICATE_RENEW_DAYS_BEFORE + 1));
        assert!(params.not_before <= now && now < params.not_after);

        let dir = temp_dir("renew");
        let addr = "127.0.0.1:7777".parse().unwrap();
        let (creds, path) = make_dev(&dir, addr).unwrap();
        ring::signature::EcdsaKeyPair::from_pkcs8(
            &ring::signature::ECDSA_P256_SHA256_ASN1_SIGNING,
            creds.cert_key.secret_der(),
            &SystemRandom::new(),
        )
        .expect("a P-256 key");

        let renewed = renew_dev(&creds, &dir, addr).unwrap();
        assert_ne!(renewed.fingerprint, creds.fingerprint, "a new certificate");
        assert_eq!(renewed.fingerprint, cert_fingerprint(&renewed.cert));
        assert_eq!(renewed.token_key, creds.token_key, "tokens stay valid");
        assert_eq!(renewed.admin_token, creds.admin_token);
        let file: DevCredentials = serde_json::from_slice(&fs::read(&path).unwrap()).unwrap();
        assert_eq!(file.fingerprint().unwrap(), renewed.fingerprint);
        assert_eq!(file.token_key_bytes().unwrap(), creds.token_key);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn dev_credentials_are_written_private_and_read_back() {
        let dir = temp_dir("dev");
        let (creds, path) = make_dev(&dir, "127.0.0.1:7777".parse().unwrap()).unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = fs::metadata(&path).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o600);
        }
        let file: DevCredentials = serde_json::from_slice(&fs::read(&path).unwrap()).unwrap();
        assert_eq!(file.fingerprint().unwrap(), creds.fingerprint);
        assert_eq!(file.token_key_bytes().unwrap(), creds.token_key);
        assert_eq!(file.server_addr, "127.0.0.1:7777");
        assert_eq!(creds.fingerprint, cert_fingerprint(&creds.cert));
        // Debug never shows the secrets.
        let shown = format!("{creds:?}");
        assert!(!shown.contains(creds.admin_token.as_deref().unwrap()));
        assert!(!shown.contains(&to_hex(&creds.token_key)));
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn production_needs_every_file_and_reads_pem() {
        let err = load(&CredentialFiles {
            key_file: Some("k".into()),
            ..Default::default()
        })
        .unwrap_err();
        assert!(
            err.to_string().contains("--cert-file, --cert-key-file"),
            "{err}"
        );

        let dir = temp_dir("prod");
        fs::create_dir_all(&dir).unwrap();
        let certified = rcgen::generate_simple_self_signed(vec!["game.example".into()]).unwrap();
        fs::write(dir.join("cert.pem"), certified.cert.pem()).unwrap();
        fs::write(dir.join("key.pem"), certified.signing_key.serialize_pem()).unwrap();
        fs::write(dir.join("token.key"), to_hex(&[7u8; 32])).unwrap();
        let files = CredentialFiles {
            key_file: Some(dir.join("token.key")),
            cert_file: Some(dir.join("cert.pem")),
            cert_key_file: Some(dir.join("key.pem")),
        };
        let creds = load(&files).unwrap();
        assert_eq!(creds.token_key, [7u8; 32]);
        assert_eq!(creds.cert.as_ref(), certified.cert.der().as_ref());

        fs::write(dir.join("token.key"), "not hex").unwrap();
        let err = load(&files).unwrap_err();
        assert!(matches!(err, CredentialsError::Invalid { .. }), "{err}");
        fs::remove_dir_all(&dir).unwrap();
    }
}
