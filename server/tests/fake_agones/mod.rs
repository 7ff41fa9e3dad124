//! A fake Agones SDK server: the sidecar's REST API (`sdk.swagger.json`
//! and `beta.swagger.json`) on a loopback port, holding one game server,
//! its counters and lists, and recording every call it is sent.
//!
//! It behaves as the real one does where the server depends on it: `Ready`,
//! `Allocate`, `Reserve` and `Shutdown` change the state, which the watch
//! stream sends; labels and annotations set through the SDK get the
//! `agones.dev/sdk-` prefix; a counter or list the game server does not
//! declare is 404, a count out of range 400. [`FakeAgones::allocate_with`]
//! does what a `GameServerAllocation` with metadata does.

#![allow(dead_code)]
// each test file uses its own subset
// A refusal is a whole response: the fake answers with it as it is.
#![allow(clippy::result_large_err)]

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use axum::body::{Body, Bytes};
use axum::http::{Method, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use inertia_server::orchestrator::sdk::{
    Counter, CounterUpdate, GameServer, KeyValue, List, ListValue, Reservation,
};
use tokio::sync::mpsc;

/// One call the fake was sent.
#[derive(Debug, Clone)]
pub struct Call {
    /// When it came.
    pub at: Instant,
    /// `POST /ready`, `PATCH /v1beta1/counters/players`, ...
    pub what: String,
    /// Its body.
    pub body: String,
}

#[derive(Debug, Default)]
struct State {
    calls: Vec<Call>,
    game_server: GameServer,
    counters: BTreeMap<String, Counter>,
    lists: BTreeMap<String, List>,
    watchers: Vec<mpsc::UnboundedSender<GameServer>>,
    /// A directory to look into when `Shutdown` comes, and what it held
    /// then (what the pod's volumes hold when Agones deletes it).
    at_shutdown: (Option<std::path::PathBuf>, Option<Vec<String>>),
}

impl State {
    /// Sends the game server to every watcher still listening.
    fn changed(&mut self) {
        let gs = self.game_server.clone();
        self.watchers.retain(|w| w.send(gs.clone()).is_ok());
    }
}

/// The fake, serving until dropped or [`FakeAgones::stop`]ped.
#[derive(Debug)]
pub struct FakeAgones {
    pub addr: SocketAddr,
    state: Arc<Mutex<State>>,
    task: tokio::task::JoinHandle<()>,
}

/// A game server as Agones would hand it over: named, with a uid, health
/// checked every `period_seconds`.
pub fn game_server(period_seconds: i32) -> GameServer {
    let mut gs = GameServer::default();
    gs.object_meta.name = "inertia-fleet-x7k2p".into();
    gs.object_meta.namespace = "default".into();
    gs.object_meta.uid = "0b6b9b3e-6b1c-4a55-9d5e-7f2a7f0d1c11".into();
    gs.object_meta.creation_timestamp = 1_796_000_000;
    gs.spec.health.period_seconds = period_seconds;
    gs.spec.health.failure_threshold = 3;
    gs.status.state = "Scheduled".into();
    gs
}

impl FakeAgones {
    /// Serves `game_server` with the `counters` and `lists` it declares,
    /// on `port` of loopback (0: any).
    pub async fn start(
        port: u16,
        game_server: GameServer,
        counters: Vec<Counter>,
        lists: Vec<List>,
    ) -> FakeAgones {
        let state = Arc::new(Mutex::new(State {
            game_server,
            counters: counters.into_iter().map(|c| (c.name.clone(), c)).collect(),
            lists: lists.into_iter().map(|l| (l.name.clone(), l)).collect(),
            ..State::default()
        }));
        let listener = tokio::net::TcpListener::bind(SocketAddr::from(([127, 0, 0, 1], port)))
            .await
            .expect("the fake SDK port");
        let addr = listener.local_addr().expect("bound");
        let shared = state.clone();
        let app = axum::Router::new().fallback(move |method: Method, uri: Uri, body: Bytes| {
            let state = shared.clone();
            async move { handle(&state, method, uri, body) }
        });
        let task = tokio::spawn(async move {
            let _ = axum::serve(listener, app).await;
        });
        FakeAgones { addr, state, task }
    }

    /// Stops serving (the port is free again once this returns).
    pub async fn stop(mut self) {
        self.task.abort();
        let task = std::mem::replace(&mut self.task, tokio::spawn(async {}));
        let _ = task.await;
        self.state.lock().unwrap().watchers.clear();
    }

    /// Every call so far, in order.
    pub fn calls(&self) -> Vec<Call> {
        self.state.lock().unwrap().calls.clone()
    }

    /// The calls so far as `METHOD /path`.
    pub fn whats(&self) -> Vec<String> {
        self.calls().into_iter().map(|c| c.what).collect()
    }

    /// How many calls were `what`.
    pub fn count(&self, what: &str) -> usize {
        self.calls().iter().filter(|c| c.what == what).count()
    }

    /// Looks into `dir` when `Shutdown` comes; [`Self::seen_at_shutdown`]
    /// says what it held.
    pub fn look_into_at_shutdown(&self, dir: std::path::PathBuf) {
        self.state.lock().unwrap().at_shutdown.0 = Some(dir);
    }

    /// The names in the directory of [`Self::look_into_at_shutdown`] when
    /// `Shutdown` came (`None` before it has).
    pub fn seen_at_shutdown(&self) -> Option<Vec<String>> {
        self.state.lock().unwrap().at_shutdown.1.clone()
    }

    /// The game server now.
    pub fn game_server(&self) -> GameServer {
        self.state.lock().unwrap().game_server.clone()
    }

    /// The counter `name` now.
    pub fn counter(&self, name: &str) -> Option<Counter> {
        self.state.lock().unwrap().counters.get(name).cloned()
    }

    /// The list `name` now.
    pub fn list(&self, name: &str) -> Option<List> {
        self.state.lock().unwrap().lists.get(name).cloned()
    }

    /// What a `GameServerAllocation` with metadata does: the labels and
    /// annotations are set and the game server is `Allocated`.
    pub fn allocate_with(&self, labels: &[(&str, &str)], annotations: &[(&str, &str)]) {
        let mut s = self.state.lock().unwrap();
        let meta = &mut s.game_server.object_meta;
        for (k, v) in labels {
            meta.labels.insert(k.to_string(), v.to_string());
        }
        for (k, v) in annotations {
            meta.annotations.insert(k.to_string(), v.to_string());
        }
        s.game_server.status.state = "Allocated".into();
        s.changed();
    }
}

impl Drop for FakeAgones {
    fn drop(&mut self) {
        self.task.abort();
    }
}

fn json<T: serde::Serialize>(value: &T) -> Response {
    (
        StatusCode::OK,
        [("content-type", "application/json")],
        serde_json::to_string(value).expect("serialisable"),
    )
        .into_response()
}

fn error(status: StatusCode, message: &str) -> Response {
    (
        status,
        [("content-type", "application/json")],
        serde_json::json!({ "code": status.as_u16(), "message": message }).to_string(),
    )
        .into_response()
}

fn parse<T: for<'de> serde::Deserialize<'de>>(body: &Bytes) -> Result<T, Response> {
    serde_json::from_slice(body).map_err(|e| error(StatusCode::BAD_REQUEST, &e.to_string()))
}

fn handle(state: &Mutex<State>, method: Method, uri: Uri, body: Bytes) -> Response {
    let path = uri.path().to_string();
    let mut s = state.lock().unwrap();
    s.calls.push(Call {
        at: Instant::now(),
        what: format!("{method} {path}"),
        body: String::from_utf8_lossy(&body).into_owned(),
    });
    match answer(&mut s, &method, &path, &body) {
        Ok(r) | Err(r) => r,
    }
}

fn answer(s: &mut State, method: &Method, path: &str, body: &Bytes) -> Result<Response, Response> {
    let empty = || json(&serde_json::json!({}));
    let set_state = |s: &mut State, to: &str| {
        s.game_server.status.state = to.into();
        s.changed();
        empty()
    };
    match (method.as_str(), path) {
        ("POST", "/ready") => Ok(set_state(s, "Ready")),
        ("POST", "/allocate") => Ok(set_state(s, "Allocated")),
        ("POST", "/shutdown") => {
            // The first Shutdown is the one Agones acts on.
            if let (Some(dir), None) = (&s.at_shutdown.0, &s.at_shutdown.1) {
                let mut names: Vec<String> = std::fs::read_dir(dir)
                    .into_iter()
                    .flatten()
                    .flatten()
                    .filter_map(|e| e.file_name().into_string().ok())
                    .collect();
                names.sort();
                s.at_shutdown.1 = Some(names);
            }
            Ok(set_state(s, "Shutdown"))
        }
        ("POST", "/health") => Ok(empty()),
        ("POST", "/reserve") => {
            let r: Reservation = parse(body)?;
            if r.seconds < 0 {
                return Err(error(StatusCode::BAD_REQUEST, "negative reservation"));
            }
            Ok(set_state(s, "Reserved"))
        }
        ("PUT", "/metadata/label" | "/metadata/annotation") => {
            let kv: KeyValue = parse(body)?;
            let key = format!("agones.dev/sdk-{}", kv.key);
            let meta = &mut s.game_server.object_meta;
            if path.ends_with("label") {
                meta.labels.insert(key, kv.value);
            } else {
                meta.annotations.insert(key, kv.value);
            }
            s.changed();
            Ok(empty())
        }
        ("GET", "/gameserver") => Ok(json(&s.game_server)),
        ("GET", "/watch/gameserver") => {
            let (tx, rx) = mpsc::unbounded_channel();
            let _ = tx.send(s.game_server.clone());
            s.watchers.push(tx);
            let lines = futures_util::stream::unfold(rx, |mut rx| async move {
                let gs = rx.recv().await?;
                let line = serde_json::json!({ "result": gs }).to_string() + "\n";
                Some((Ok::<_, std::io::Error>(line), rx))
            });
            Ok(Response::new(Body::from_stream(lines)))
        }
        _ => beta(s, method, path, body),
    }
}

/// Counters and lists.
fn beta(s: &mut State, method: &Method, path: &str, body: &Bytes) -> Result<Response, Response> {
    let not_found = || error(StatusCode::NOT_FOUND, "not declared by the game server");
    if let Some(name) = path.strip_prefix("/v1beta1/counters/") {
        let counter = s.counters.get_mut(name).ok_or_else(not_found)?;
        return match method.as_str() {
            "GET" => Ok(json(counter)),
            "PATCH" => {
                let u: CounterUpdate = parse(body)?;
                let mut next = counter.clone();
                if let Some(c) = u.capacity {
                    next.capacity = c;
                }
                if let Some(c) = u.count {
                    next.count = c;
                }
                if let Some(d) = u.count_diff {
                    next.count += d;
                }
                if next.capacity < 0 || !(0..=next.capacity).contains(&next.count) {
                    return Err(error(StatusCode::BAD_REQUEST, "count out of range"));
                }
                *counter = next;
                Ok(json(counter))
            }
            _ => Err(error(StatusCode::METHOD_NOT_ALLOWED, "")),
        };
    }
    if let Some(rest) = path.strip_prefix("/v1beta1/lists/") {
        let (name, verb) = rest.split_once(':').unwrap_or((rest, ""));
        let list = s.lists.get_mut(name).ok_or_else(not_found)?;
        return match (method.as_str(), verb) {
            ("GET", "") => Ok(json(list)),
            ("PATCH", "") => {
                let l: List = parse(body)?;
                if l.values.len() as i64 > l.capacity {
                    return Err(error(StatusCode::BAD_REQUEST, "over capacity"));
                }
                list.values = l.values;
                list.capacity = l.capacity;
                Ok(json(list))
            }
            ("POST", "addValue") => {
                let v: ListValue = parse(body)?;
                if list.values.contains(&v.value) {
                    return Err(error(StatusCode::CONFLICT, "already in the list"));
                }
                if list.values.len() as i64 >= list.capacity {
                    return Err(error(StatusCode::BAD_REQUEST, "list full"));
                }
                list.values.push(v.value);
                Ok(json(list))
            }
            ("POST", "removeValue") => {
                let v: ListValue = parse(body)?;
                let before = list.values.len();
                list.values.retain(|x| *x != v.value);
                if list.values.len() == before {
                    return Err(not_found());
                }
                Ok(json(list))
            }
            _ => Err(error(StatusCode::METHOD_NOT_ALLOWED, "")),
        };
    }
    Err(error(StatusCode::NOT_FOUND, "no such path"))
}
