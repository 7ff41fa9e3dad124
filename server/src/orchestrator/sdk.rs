//! A client of the Agones SDK server's REST API: the sidecar Agones runs in
//! every game server's pod, on `localhost:$AGONES_SDK_HTTP_PORT` (9358 by
//! default).
//!
//! REST rather than gRPC: the sidecar serves both (its REST side is a
//! grpc-gateway over the same service), and REST needs no `protoc` at
//! build time, no generated code and no second HTTP/2 stack beside the one
//! the metrics endpoint already has; every call is one small request on
//! loopback, a few a second at most. The paths and bodies are those of
//! Agones's `sdk.swagger.json` and `beta.swagger.json` (64-bit integers
//! travel as JSON strings, as grpc-gateway writes them).
//!
//! Each call opens its own HTTP/1.1 connection to the sidecar and has
//! [`Sdk::timeout`] to answer; [`Sdk::watch`] keeps one open and yields the
//! game server each time Agones changes it.

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::time::Duration;

use bytes::Bytes;
use http_body_util::{BodyExt, Full};
use hyper::body::Incoming;
use hyper::{Method, Request, StatusCode};
use hyper_util::rt::TokioIo;
use serde::{Deserialize, Serialize};

/// The sidecar's REST port when `AGONES_SDK_HTTP_PORT` is not set.
pub const DEFAULT_HTTP_PORT: u16 = 9358;
/// How long one call may take before it counts as failed.
pub const CALL_TIMEOUT: Duration = Duration::from_secs(2);

/// Why a call to the SDK server failed.
#[derive(Debug, thiserror::Error)]
pub enum SdkError {
    /// Nothing listens on the SDK port (the sidecar has not started yet,
    /// or has gone away).
    #[error("the Agones SDK server at {addr} is not reachable: {source}")]
    Unreachable {
        addr: SocketAddr,
        source: std::io::Error,
    },
    /// The call took longer than [`Sdk::timeout`].
    #[error("the Agones SDK server did not answer {path} within {timeout:?}")]
    Timeout { path: String, timeout: Duration },
    /// The HTTP exchange itself failed (the connection dropped mid-way).
    #[error("HTTP failed talking to the Agones SDK server ({path}): {why}")]
    Http { path: String, why: String },
    /// The SDK server answered with an error status (a counter or list
    /// the game server does not declare is 404; a count out of range, 400).
    #[error("the Agones SDK server refused {path}: HTTP {status}: {body}")]
    Refused {
        path: String,
        status: u16,
        body: String,
    },
    /// The answer was not the JSON the API describes.
    #[error("the Agones SDK server's answer to {path} did not parse: {why}")]
    Decode { path: String, why: String },
}

impl SdkError {
    /// Whether the call was refused as naming something that does not
    /// exist (a counter or list the game server does not declare).
    pub fn is_not_found(&self) -> bool {
        matches!(self, SdkError::Refused { status: 404, .. })
    }
}

/// The game server as the SDK shows it (the fields Inertia reads).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GameServer {
    #[serde(default)]
    pub object_meta: ObjectMeta,
    #[serde(default)]
    pub spec: GameServerSpec,
    #[serde(default)]
    pub status: GameServerStatus,
}

/// Name, identity and metadata of a game server.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectMeta {
    #[serde(default)]
    pub name: String,
    #[serde(default)]
    pub namespace: String,
    #[serde(default)]
    pub uid: String,
    /// Seconds since the Unix epoch.
    #[serde(default, with = "int64")]
    pub creation_timestamp: i64,
    #[serde(default)]
    pub labels: BTreeMap<String, String>,
    #[serde(default)]
    pub annotations: BTreeMap<String, String>,
}

/// What the game server's spec says the SDK needs to know.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GameServerSpec {
    #[serde(default)]
    pub health: HealthSpec,
}

/// How Agones checks the game server's health pings.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct HealthSpec {
    /// Health checking is off.
    #[serde(default)]
    pub disabled: bool,
    /// A ping is expected at least this often, s (0: Agones's default, 5).
    #[serde(default)]
    pub period_seconds: i32,
    /// Periods without a ping before the game server is Unhealthy.
    #[serde(default)]
    pub failure_threshold: i32,
    /// Grace before the first ping is expected, s.
    #[serde(default)]
    pub initial_delay_seconds: i32,
}

/// The game server's state and address.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GameServerStatus {
    /// `Scheduled`, `RequestReady`, `Ready`, `Reserved`, `Allocated`,
    /// `Shutdown`, `Unhealthy`, ...
    #[serde(default)]
    pub state: String,
    #[serde(default)]
    pub address: String,
}

/// A named counter of the game server (Agones's Counts and Lists).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counter {
    #[serde(default)]
    pub name: String,
    #[serde(default, with = "int64")]
    pub count: i64,
    #[serde(default, with = "int64")]
    pub capacity: i64,
}

/// A change to a counter: any of the three (absent ones stay).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct CounterUpdate {
    #[serde(default, skip_serializing_if = "Option::is_none", with = "opt_int64")]
    pub count: Option<i64>,
    #[serde(default, skip_serializing_if = "Option::is_none", with = "opt_int64")]
    pub capacity: Option<i64>,
    #[serde(default, skip_serializing_if = "Option::is_none", with = "opt_int64")]
    pub count_diff: Option<i64>,
}

/// A named list of values of the game server (Agones's Counts and Lists).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct List {
    #[serde(default)]
    pub name: String,
    #[serde(default, with = "int64")]
    pub capacity: i64,
    #[serde(default)]
    pub values: Vec<String>,
}

/// A key and value, for labels and annotations.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct KeyValue {
    pub key: String,
    pub value: String,
}

/// How long to hold a game server reserved.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Reservation {
    #[serde(with = "int64")]
    pub seconds: i64,
}

/// One value added to or removed from a list.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ListValue {
    pub value: String,
}

/// One line of the watch stream (grpc-gateway wraps each message).
#[derive(Debug, Deserialize)]
struct WatchLine {
    result: Option<GameServer>,
    error: Option<serde_json::Value>,
}

/// The SDK server's REST API.
#[derive(Debug, Clone)]
pub struct Sdk {
    addr: SocketAddr,
    timeout: Duration,
}

impl Sdk {
    /// The SDK server on loopback at `port`.
    pub fn on_port(port: u16) -> Sdk {
        Sdk {
            addr: SocketAddr::from(([127, 0, 0, 1], port)),
            timeout: CALL_TIMEOUT,
        }
    }

    /// The SDK server's address.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// How long each call may take.
    pub fn timeout(&self) -> Duration {
        self.timeout
    }

    /// The game server is ready for players (`POST /ready`).
    pub async fn ready(&self) -> Result<(), SdkError> {
        self.empty(Method::POST, "/ready").await
    }

    /// One health ping (`POST /health`).
    pub async fn health(&self) -> Result<(), SdkError> {
        self.empty(Method::POST, "/health").await
    }

    /// Allocates this game server itself (`POST /allocate`).
    pub async fn allocate(&self) -> Result<(), SdkError> {
        self.empty(Method::POST, "/allocate").await
    }

    /// The game server is done: Agones deletes it (`POST /shutdown`).
    pub async fn shutdown(&self) -> Result<(), SdkError> {
        self.empty(Method::POST, "/shutdown").await
    }

    /// Holds the game server out of allocation and scale-down for
    /// `seconds` (`POST /reserve`).
    pub async fn reserve(&self, seconds: i64) -> Result<(), SdkError> {
        self.call(Method::POST, "/reserve", Some(&Reservation { seconds }))
            .await
            .map(drop)
    }

    /// Sets label `agones.dev/sdk-<key>` (`PUT /metadata/label`).
    pub async fn set_label(&self, key: &str, value: &str) -> Result<(), SdkError> {
        self.key_value("/metadata/label", key, value).await
    }

    /// Sets annotation `agones.dev/sdk-<key>` (`PUT /metadata/annotation`).
    pub async fn set_annotation(&self, key: &str, value: &str) -> Result<(), SdkError> {
        self.key_value("/metadata/annotation", key, value).await
    }

    /// The game server now (`GET /gameserver`).
    pub async fn game_server(&self) -> Result<GameServer, SdkError> {
        let path = "/gameserver";
        let body = self.call::<()>(Method::GET, path, None).await?;
        decode(path, &body)
    }

    /// The counter `name` (`GET /v1beta1/counters/{name}`).
    pub async fn counter(&self, name: &str) -> Result<Counter, SdkError> {
        let path = format!("/v1beta1/counters/{}", path_segment(name));
        let body = self.call::<()>(Method::GET, &path, None).await?;
        decode(&path, &body)
    }

    /// Changes the counter `name` and returns it as it is now
    /// (`PATCH /v1beta1/counters/{name}`).
    pub async fn update_counter(
        &self,
        name: &str,
        update: &CounterUpdate,
    ) -> Result<Counter, SdkError> {
        let path = format!("/v1beta1/counters/{}", path_segment(name));
        let body = self.call(Method::PATCH, &path, Some(update)).await?;
        decode(&path, &body)
    }

    /// The list `name` (`GET /v1beta1/lists/{name}`).
    pub async fn list(&self, name: &str) -> Result<List, SdkError> {
        let path = format!("/v1beta1/lists/{}", path_segment(name));
        let body = self.call::<()>(Method::GET, &path, None).await?;
        decode(&path, &body)
    }

    /// Replaces the values and capacity of the list `name`
    /// (`PATCH /v1beta1/lists/{name}`).
    pub async fn update_list(&self, list: &List) -> Result<List, SdkError> {
        let path = format!("/v1beta1/lists/{}", path_segment(&list.name));
        let body = self.call(Method::PATCH, &path, Some(list)).await?;
        decode(&path, &body)
    }

    /// Adds `value` to the list `name`
    /// (`POST /v1beta1/lists/{name}:addValue`).
    pub async fn add_list_value(&self, name: &str, value: &str) -> Result<List, SdkError> {
        self.list_value(name, "addValue", value).await
    }

    /// Removes `value` from the list `name`
    /// (`POST /v1beta1/lists/{name}:removeValue`).
    pub async fn remove_list_value(&self, name: &str, value: &str) -> Result<List, SdkError> {
        self.list_value(name, "removeValue", value).await
    }

    /// Opens the watch stream (`GET /watch/gameserver`): the game server
    /// now, then each time it changes.
    pub async fn watch(&self) -> Result<Watch, SdkError> {
        let path = "/watch/gameserver";
        let response = self.send::<()>(Method::GET, path, None).await?;
        let status = response.status();
        if status != StatusCode::OK {
            let body = read_body(path, response.into_body()).await?;
            return Err(refused(path, status, &body));
        }
        Ok(Watch {
            body: response.into_body(),
            pending: Vec::new(),
        })
    }

    async fn empty(&self, method: Method, path: &str) -> Result<(), SdkError> {
        // The API takes an empty message as the body.
        self.call(method, path, Some(&serde_json::json!({})))
            .await
            .map(drop)
    }

    async fn key_value(&self, path: &str, key: &str, value: &str) -> Result<(), SdkError> {
        let kv = KeyValue {
            key: key.to_string(),
            value: value.to_string(),
        };
        self.call(Method::PUT, path, Some(&kv)).await.map(drop)
    }

    async fn list_value(&self, name: &str, verb: &str, value: &str) -> Result<List, SdkError> {
        let path = format!("/v1beta1/lists/{}:{verb}", path_segment(name));
        let body = ListValue {
            value: value.to_string(),
        };
        let answer = self.call(Method::POST, &path, Some(&body)).await?;
        decode(&path, &answer)
    }

    /// One request and its whole answer, which must be 200.
    async fn call<B: Serialize>(
        &self,
        method: Method,
        path: &str,
        body: Option<&B>,
    ) -> Result<Bytes, SdkError> {
        let timeout = self.timeout;
        let exchange = async {
            let response = self.send(method, path, body).await?;
            let status = response.status();
            let bytes = read_body(path, response.into_body()).await?;
            if status == StatusCode::OK {
                Ok(bytes)
            } else {
                Err(refused(path, status, &bytes))
            }
        };
        match tokio::time::timeout(timeout, exchange).await {
            Ok(result) => result,
            Err(_) => Err(SdkError::Timeout {
                path: path.to_string(),
                timeout,
            }),
        }
    }

    /// Connects, sends one request and returns the answer's head (its
    /// body still to read).
    async fn send<B: Serialize>(
        &self,
        method: Method,
        path: &str,
        body: Option<&B>,
    ) -> Result<hyper::Response<Incoming>, SdkError> {
        let http = |why: String| SdkError::Http {
            path: path.to_string(),
            why,
        };
        let connect = tokio::net::TcpStream::connect(self.addr);
        let stream = match tokio::time::timeout(self.timeout, connect).await {
            Ok(Ok(stream)) => stream,
            Ok(Err(source)) => {
                return Err(SdkError::Unreachable {
                    addr: self.addr,
                    source,
                })
            }
            Err(_) => {
                return Err(SdkError::Timeout {
                    path: path.to_string(),
                    timeout: self.timeout,
                })
            }
        };
        let (mut sender, connection) = hyper::client::conn::http1::handshake(TokioIo::new(stream))
            .await
            .map_err(|e| http(e.to_string()))?;
        // The connection runs until the answer (or the watch stream) ends.
        tokio::spawn(async move {
            let _ = connection.await;
        });
        let bytes = match body {
            Some(b) => Bytes::from(serde_json::to_vec(b).map_err(|e| http(e.to_string()))?),
            None => Bytes::new(),
        };
        let request = Request::builder()
            .method(method)
            .uri(path)
            .header(hyper::header::HOST, "localhost")
            .header(hyper::header::CONTENT_TYPE, "application/json")
            .body(Full::new(bytes))
            .map_err(|e| http(e.to_string()))?;
        sender
            .send_request(request)
            .await
            .map_err(|e| http(e.to_string()))
    }
}

/// The watch stream of [`Sdk::watch`].
#[derive(Debug)]
pub struct Watch {
    body: Incoming,
    /// Bytes received after the last whole line.
    pending: Vec<u8>,
}

impl Watch {
    /// The next version of the game server; `Ok(None)` once the SDK server
    /// ends the stream.
    pub async fn next(&mut self) -> Result<Option<GameServer>, SdkError> {
        let path = "/watch/gameserver";
        loop {
            if let Some(end) = self.pending.iter().position(|&b| b == b'\n') {
                let line: Vec<u8> = self.pending.drain(..=end).collect();
                if line.iter().all(u8::is_ascii_whitespace) {
                    continue;
                }
                let parsed: WatchLine =
                    serde_json::from_slice(&line).map_err(|e| SdkError::Decode {
                        path: path.to_string(),
                        why: e.to_string(),
                    })?;
                if let Some(error) = parsed.error {
                    return Err(SdkError::Refused {
                        path: path.to_string(),
                        status: 200,
                        body: error.to_string(),
                    });
                }
                match parsed.result {
                    Some(gs) => return Ok(Some(gs)),
                    None => continue,
                }
            }
            match self.body.frame().await {
                None => return Ok(None),
                Some(Err(e)) => {
                    return Err(SdkError::Http {
                        path: path.to_string(),
                        why: e.to_string(),
                    })
                }
                Some(Ok(frame)) => {
                    if let Some(data) = frame.data_ref() {
                        self.pending.extend_from_slice(data);
                        if self.pending.len() > MAX_WATCH_LINE {
                            return Err(SdkError::Decode {
                                path: path.to_string(),
                                why: format!("a line longer than {MAX_WATCH_LINE} bytes"),
                            });
                        }
                    }
                }
            }
        }
    }
}

/// Longest line the watch stream may send (a game server with its
/// labels and annotations is a few KB).
const MAX_WATCH_LINE: usize = 1 << 20;
/// Longest answer read from any other call.
const MAX_BODY: usize = 1 << 20;

async fn read_body(path: &str, body: Incoming) -> Result<Bytes, SdkError> {
    let limited = http_body_util::Limited::new(body, MAX_BODY);
    limited
        .collect()
        .await
        .map(|c| c.to_bytes())
        .map_err(|e| SdkError::Http {
            path: path.to_string(),
            why: e.to_string(),
        })
}

fn refused(path: &str, status: StatusCode, body: &[u8]) -> SdkError {
    let mut text = String::from_utf8_lossy(body).into_owned();
    let mut end = text.len().min(512);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    text.truncate(end);
    SdkError::Refused {
        path: path.to_string(),
        status: status.as_u16(),
        body: text,
    }
}

fn decode<T: for<'de> Deserialize<'de>>(path: &str, body: &[u8]) -> Result<T, SdkError> {
    serde_json::from_slice(body).map_err(|e| SdkError::Decode {
        path: path.to_string(),
        why: e.to_string(),
    })
}

/// A counter or list name as one path segment: the characters Kubernetes
/// allows in a name pass through; anything else is percent-encoded.
fn path_segment(name: &str) -> String {
    let mut out = String::with_capacity(name.len());
    for b in name.bytes() {
        if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.') {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// 64-bit integers as grpc-gateway writes them: JSON strings (numbers are
/// read too).
pub(crate) mod int64 {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &i64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&v.to_string())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<i64, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Either {
            Text(String),
            Number(i64),
        }
        match Either::deserialize(d)? {
            Either::Number(n) => Ok(n),
            Either::Text(t) if t.is_empty() => Ok(0),
            Either::Text(t) => t.parse().map_err(serde::de::Error::custom),
        }
    }
}

/// [`int64`] for optional fields.
pub(crate) mod opt_int64 {
    use serde::{Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &Option<i64>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(v) => super::int64::serialize(v, s),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<i64>, D::Error> {
        super::int64::deserialize(d).map(Some)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn int64_travels_as_a_string_and_reads_either() {
        let c = Counter {
            name: "players".into(),
            count: 3,
            capacity: 64,
        };
        let text = serde_json::to_string(&c).unwrap();
        assert_eq!(text, r#"{"name":"players","count":"3","capacity":"64"}"#);
        let back: Counter =
            serde_json::from_str(r#"{"name":"p","count":5,"capacity":"7"}"#).unwrap();
        assert_eq!((back.count, back.capacity), (5, 7));
        assert!(serde_json::from_str::<Counter>(r#"{"count":"five"}"#).is_err());
    }

    #[test]
    fn a_counter_update_sends_only_what_it_changes() {
        let u = CounterUpdate {
            count_diff: Some(-1),
            ..CounterUpdate::default()
        };
        assert_eq!(serde_json::to_string(&u).unwrap(), r#"{"countDiff":"-1"}"#);
    }

    #[test]
    fn names_are_one_path_segment() {
        assert_eq!(path_segment("players"), "players");
        assert_eq!(path_segment("a/b c"), "a%2Fb%20c");
    }
}
