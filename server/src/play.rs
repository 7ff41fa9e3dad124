//! The browser page at `/play`, on the metrics listener: its HTML (compiled
//! in), its modules (the TypeScript build of `web/`, read from the web
//! directory), and on a dev server a session for the page: a fresh connect
//! token, the WebTransport URL and the certificate hash to pin.
//!
//! A session is handed out only by a dev-mode server, only to a peer on a
//! loopback address, and only to a request that names this server: its
//! `Host` (and its `Origin`, when a browser sends one) must be `localhost`
//! or a loopback address, on the port the page is served from. A page of
//! another origin can reach a loopback port through DNS rebinding (its own
//! name made to resolve to 127.0.0.1), but the browser then sends that
//! name as the `Host`, and is refused. A session admits whoever asks, as
//! the dev credentials file does for whoever can read it.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use axum::extract::{ConnectInfo, Path as UrlPath, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use inertia_protocol::control::WEB_TRANSPORT_PATH;
use inertia_protocol::credentials::{to_hex, DevCredentials};

/// The page, with the modules it loads from beside it.
pub const PAGE_HTML: &str = include_str!("../../web/play/index.html");

/// How long a page's connect token is valid, s.
const SESSION_TOKEN_TTL: u64 = 60;

/// Where the page's parts come from.
#[derive(Debug, Clone, Default)]
pub struct PlayConfig {
    /// The page's modules (`web/dist/src`), if built.
    pub web_dir: Option<PathBuf>,
    /// A dev server's credentials file: sessions are handed out from it.
    pub dev_credentials: Option<PathBuf>,
    /// The port the page is served from: a session's request must name
    /// it when its `Host` or `Origin` has a port (`None`: any port).
    pub port: Option<u16>,
}

impl PlayConfig {
    /// The web directory given, else `web/dist/src` under the working
    /// directory when it exists.
    pub fn find_web_dir(given: Option<&Path>) -> Option<PathBuf> {
        match given {
            Some(dir) => Some(dir.to_path_buf()),
            None => {
                let built = Path::new("web/dist/src");
                built.join("play.js").is_file().then(|| built.to_path_buf())
            }
        }
    }
}

/// The routes: `/play`, `/play/` (the page), `/play/session` and
/// `/play/{module}.js`.
pub fn router(config: PlayConfig) -> Router {
    Router::new()
        .route("/play", get(page))
        .route("/play/", get(page))
        .route("/play/session", get(session))
        .route("/play/{file}", get(module))
        .with_state(config)
}

async fn page() -> impl IntoResponse {
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        PAGE_HTML,
    )
}

/// True for the names of the page's modules: lower-case letters, digits,
/// `_` and `-`, then `.js`; never a path.
pub fn is_module_name(name: &str) -> bool {
    name.strip_suffix(".js").is_some_and(|stem| {
        !stem.is_empty()
            && stem.len() <= 64
            && stem
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_' || b == b'-')
    })
}

async fn module(State(config): State<PlayConfig>, UrlPath(file): UrlPath<String>) -> Response {
    if !is_module_name(&file) {
        return (StatusCode::NOT_FOUND, "no such module\n").into_response();
    }
    let Some(dir) = &config.web_dir else {
        return (
            StatusCode::NOT_FOUND,
            "the page is not built: cd web && npm ci && npm run build (or give --web-dir)\n",
        )
            .into_response();
    };
    let path = dir.join(&file);
    match tokio::task::spawn_blocking(move || std::fs::read(path)).await {
        Ok(Ok(bytes)) => (
            [
                (header::CONTENT_TYPE, "text/javascript; charset=utf-8"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            bytes,
        )
            .into_response(),
        _ => (StatusCode::NOT_FOUND, "no such module\n").into_response(),
    }
}

/// What the page needs to join: JSON `{ url, cert_hash, token }` (hex).
async fn session(
    State(config): State<PlayConfig>,
    ConnectInfo(peer): ConnectInfo<SocketAddr>,
    headers: HeaderMap,
) -> Response {
    let Some(path) = &config.dev_credentials else {
        return (
            StatusCode::NOT_FOUND,
            "sessions are handed out by dev-mode servers only; a game's backend mints tokens\n",
        )
            .into_response();
    };
    if !peer.ip().is_loopback() {
        return (
            StatusCode::FORBIDDEN,
            "sessions go to loopback peers only\n",
        )
            .into_response();
    }
    if let Err(why) = names_this_server(&headers, config.port) {
        return (StatusCode::FORBIDDEN, format!("{why}\n")).into_response();
    }
    match mint_session(path) {
        Ok(json) => (
            [
                (header::CONTENT_TYPE, "application/json"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            json,
        )
            .into_response(),
        Err(why) => (StatusCode::INTERNAL_SERVER_ERROR, format!("{why}\n")).into_response(),
    }
}

/// Why a request for a session does not name this server.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ForeignRequest {
    /// The request has no `Host`, or one that is not text.
    #[error("the request names no host")]
    NoHost,
    /// Its `Host` is not this server on loopback.
    #[error("sessions go to pages served from localhost only, not from host {0:?}")]
    Host(String),
    /// Its `Origin` is not this server on loopback.
    #[error("sessions go to pages served from localhost only, not to origin {0:?}")]
    Origin(String),
}

/// Checks that a request names this server: its `Host`, and its `Origin`
/// if it has one, are `localhost` or a loopback address, on `port` when
/// they give one.
pub fn names_this_server(headers: &HeaderMap, port: Option<u16>) -> Result<(), ForeignRequest> {
    let host = headers
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .ok_or(ForeignRequest::NoHost)?;
    if !is_loopback_authority(host, port) {
        return Err(ForeignRequest::Host(host.to_string()));
    }
    if let Some(origin) = headers.get(header::ORIGIN) {
        let text = origin.to_str().unwrap_or("");
        // An origin always names its port, if only by its scheme's default.
        let named = |authority: &str, default: u16| {
            if authority
                .rsplit_once(':')
                .is_some_and(|(_, p)| !p.contains(']'))
            {
                authority.to_string()
            } else {
                format!("{authority}:{default}")
            }
        };
        let authority = text
            .strip_prefix("http://")
            .map(|a| named(a, 80))
            .or_else(|| text.strip_prefix("https://").map(|a| named(a, 443)));
        if !authority.is_some_and(|a| is_loopback_authority(&a, port)) {
            return Err(ForeignRequest::Origin(text.to_string()));
        }
    }
    Ok(())
}

/// Whether `authority` (`host[:port]`, as a `Host` header or an origin
/// writes it) is `localhost` or a loopback address, with `port` if it
/// gives one.
pub fn is_loopback_authority(authority: &str, port: Option<u16>) -> bool {
    let (host, given_port) = match authority.rsplit_once(':') {
        // `[::1]` alone: the colon is inside the brackets.
        Some((host, p)) if !p.contains(']') => match p.parse::<u16>() {
            Ok(p) => (host, Some(p)),
            Err(_) => return false,
        },
        _ => (authority, None),
    };
    let port_ok = match (given_port, port) {
        (Some(given), Some(served)) => given == served,
        _ => true,
    };
    let host_ok = if host.eq_ignore_ascii_case("localhost") {
        true
    } else if let Some(v6) = host.strip_prefix('[').and_then(|h| h.strip_suffix(']')) {
        v6.parse::<std::net::Ipv6Addr>()
            .is_ok_and(|ip| ip.is_loopback())
    } else {
        host.parse::<std::net::Ipv4Addr>()
            .is_ok_and(|ip| ip.is_loopback())
    };
    port_ok && host_ok
}

/// A session from the dev credentials file at `path` (read afresh: the
/// certificate is renewed while the server runs).
pub fn mint_session(path: &Path) -> Result<String, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let creds: DevCredentials =
        serde_json::from_slice(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    let addr: SocketAddr = creds
        .server_addr
        .parse()
        .map_err(|e| format!("server_addr: {e}"))?;
    let now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let mut id = [0u8; 8];
    ring::rand::SecureRandom::fill(&ring::rand::SystemRandom::new(), &mut id)
        .map_err(|_| "no randomness for a client id".to_string())?;
    // Below 2^53: a JavaScript number holds it.
    let client_id = u64::from_le_bytes(id) >> 11;
    let token = creds
        .mint_token(client_id, SESSION_TOKEN_TTL, now)
        .map_err(|e| e.to_string())?;
    Ok(serde_json::json!({
        "url": format!("https://{}:{}{WEB_TRANSPORT_PATH}", host(addr), addr.port()),
        // Checked by the minting, which seals it into the token.
        "cert_hash": creds.cert_fingerprint,
        "token": to_hex(&token.to_bytes()),
        "client_id": client_id,
    })
    .to_string())
}

/// `addr`'s host as a URL writes it.
fn host(addr: SocketAddr) -> String {
    match addr {
        SocketAddr::V4(a) => a.ip().to_string(),
        SocketAddr::V6(a) => format!("[{}]", a.ip()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_plain_module_names_are_served() {
        for good in ["play.js", "snapshot.js", "bits-2.js", "a_b.js"] {
            assert!(is_module_name(good), "{good}");
        }
        for bad in [
            "../play.js",
            "play.ts",
            ".js",
            "Play.js",
            "a/b.js",
            "a%2fb.js",
            "play.js.map",
            "",
            "..",
        ] {
            assert!(!is_module_name(bad), "{bad}");
        }
    }

    #[test]
    fn issue_42_a_session_goes_only_to_requests_that_name_this_server() {
        let port = Some(9100);
        for good in [
            "localhost",
            "localhost:9100",
            "LOCALHOST:9100",
            "127.0.0.1:9100",
            "127.1.2.3",
            "[::1]:9100",
            "[::1]",
        ] {
            assert!(is_loopback_authority(good, port), "{good}");
        }
        for bad in [
            "evil.example",
            "evil.example:9100",
            "localhost.evil.example:9100",
            "localhost:9101",
            "127.0.0.1:80",
            "10.0.0.1:9100",
            "0.0.0.0:9100",
            "[::2]:9100",
            "[::1:9100",
            "localhost:",
            "localhost:x",
            "",
        ] {
            assert!(!is_loopback_authority(bad, port), "{bad}");
        }

        let headers = |pairs: &[(header::HeaderName, &str)]| {
            let mut h = HeaderMap::new();
            for (name, value) in pairs {
                h.insert(name, value.parse().expect("a header value"));
            }
            h
        };
        assert_eq!(
            names_this_server(&headers(&[(header::HOST, "127.0.0.1:9100")]), port),
            Ok(())
        );
        assert_eq!(
            names_this_server(
                &headers(&[
                    (header::HOST, "localhost:9100"),
                    (header::ORIGIN, "http://localhost:9100")
                ]),
                port
            ),
            Ok(())
        );
        // DNS rebinding: the attacker's name resolves to loopback, and
        // the browser sends it as the host.
        assert_eq!(
            names_this_server(
                &headers(&[(header::HOST, "rebind.evil.example:9100")]),
                port
            ),
            Err(ForeignRequest::Host("rebind.evil.example:9100".into()))
        );
        assert_eq!(
            names_this_server(
                &headers(&[
                    (header::HOST, "127.0.0.1:9100"),
                    (header::ORIGIN, "http://evil.example")
                ]),
                port
            ),
            Err(ForeignRequest::Origin("http://evil.example".into()))
        );
        assert_eq!(
            names_this_server(
                &headers(&[(header::HOST, "127.0.0.1:9100"), (header::ORIGIN, "null")]),
                port
            ),
            Err(ForeignRequest::Origin("null".into()))
        );
        // An origin without a port is at its scheme's default, not this
        // server's.
        assert_eq!(
            names_this_server(
                &headers(&[
                    (header::HOST, "127.0.0.1:9100"),
                    (header::ORIGIN, "http://localhost")
                ]),
                port
            ),
            Err(ForeignRequest::Origin("http://localhost".into()))
        );
        assert_eq!(
            names_this_server(&HeaderMap::new(), port),
            Err(ForeignRequest::NoHost)
        );
    }
}
