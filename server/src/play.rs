//! The browser page at `/play`, on the metrics listener: its HTML (compiled
//! in), its modules (the TypeScript build of `web/`, read from the web
//! directory), and on a dev server a session for the page: a fresh connect
//! token, the WebTransport URL and the certificate hash to pin.
//!
//! A session is handed out only by a dev-mode server and only to a peer
//! on a loopback address: it admits whoever asks, as the dev credentials
//! file does for whoever can read it.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use axum::extract::{ConnectInfo, Path as UrlPath, State};
use axum::http::{header, StatusCode};
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
}
