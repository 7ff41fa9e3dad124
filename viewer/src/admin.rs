//! The operator's link: the admin connection on a thread of its own, so the
//! picture never waits for the server. It sends the HUD's clock requests
//! (pause, step, speed, reverse, seek) in order, asks for the server's
//! status after each, and otherwise once a second (every call is in the
//! server's audit log, so the viewer asks no more often than that).

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use inertia_admin_client::AdminClient;
use inertia_protocol::admin::{AdminRequest, AdminResponse, StatusReport};
use tokio::sync::mpsc;

/// How often the status is asked for when nothing else is sent.
const STATUS_EVERY: Duration = Duration::from_secs(1);
/// How long to wait before connecting again after a failure.
const RECONNECT_AFTER: Duration = Duration::from_secs(2);
/// The operator name the server logs for the viewer's calls.
const OPERATOR: &str = "inertia-viewer";

/// What the link knows, for the HUD.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AdminView {
    /// True while connected.
    pub connected: bool,
    /// The newest status report.
    pub status: Option<StatusReport>,
    /// The last failure or refusal, to show the operator.
    pub last_error: Option<String>,
}

/// A running admin link. Dropping it ends the thread.
#[derive(Debug)]
pub struct AdminLink {
    requests: mpsc::UnboundedSender<AdminRequest>,
    view: Arc<Mutex<AdminView>>,
}

impl AdminLink {
    /// Starts connecting with the admin credential of the dev credentials
    /// file `credentials` (at `addr` when given).
    pub fn start(credentials: PathBuf, addr: Option<SocketAddr>) -> std::io::Result<Self> {
        let (requests, rx) = mpsc::unbounded_channel();
        let view = Arc::new(Mutex::new(AdminView::default()));
        let shared = Arc::clone(&view);
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()?;
        std::thread::Builder::new()
            .name("inertia-viewer-admin".into())
            .spawn(move || runtime.block_on(run(credentials, addr, rx, shared)))?;
        Ok(Self { requests, view })
    }

    /// Queues `request`; its answer shows in [`AdminView::last_error`] if it
    /// is refused.
    pub fn send(&self, request: AdminRequest) {
        let _ = self.requests.send(request);
    }

    /// What the link knows now.
    pub fn view(&self) -> AdminView {
        self.view.lock().map(|v| v.clone()).unwrap_or_default()
    }
}

fn update(view: &Mutex<AdminView>, f: impl FnOnce(&mut AdminView)) {
    if let Ok(mut v) = view.lock() {
        f(&mut v);
    }
}

async fn run(
    credentials: PathBuf,
    addr: Option<SocketAddr>,
    mut requests: mpsc::UnboundedReceiver<AdminRequest>,
    view: Arc<Mutex<AdminView>>,
) {
    loop {
        let mut client = match AdminClient::connect_dev(&credentials, addr, OPERATOR).await {
            Ok(c) => c,
            Err(e) => {
                update(&view, |v| {
                    v.connected = false;
                    v.last_error = Some(format!("admin: {e}"));
                });
                tokio::time::sleep(RECONNECT_AFTER).await;
                continue;
            }
        };
        update(&view, |v| v.connected = true);
        let mut tick = tokio::time::interval(STATUS_EVERY);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let failure = loop {
            let request = tokio::select! {
                r = requests.recv() => match r {
                    Some(r) => r,
                    // The viewer has gone.
                    None => { client.close().await; return; }
                },
                _ = tick.tick() => AdminRequest::Status,
            };
            let status_after = request != AdminRequest::Status;
            match client.call(request.clone()).await {
                Ok(AdminResponse::Status(report)) => update(&view, |v| v.status = Some(report)),
                Ok(AdminResponse::Error(e)) => update(&view, |v| {
                    v.last_error = Some(format!("{request:?}: {}", e.message))
                }),
                Ok(_) => update(&view, |v| v.last_error = None),
                Err(e) => break e,
            }
            if status_after {
                // What the request changed, shown at once.
                match client.call(AdminRequest::Status).await {
                    Ok(AdminResponse::Status(report)) => update(&view, |v| v.status = Some(report)),
                    Ok(_) => {}
                    Err(e) => break e,
                }
                tick.reset();
            }
        };
        update(&view, |v| {
            v.connected = false;
            v.last_error = Some(format!("admin: {failure}"));
        });
        tokio::time::sleep(RECONNECT_AFTER).await;
    }
}
