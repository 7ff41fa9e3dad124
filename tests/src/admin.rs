//! The admin channel and the client's catalog, as the end-to-end tests use
//! them: an admitted `AdminClient`, calls that must answer as expected,
//! and waiting for a condition.

use std::future::Future;
use std::time::{Duration, Instant};

use inertia_admin_client::{read_credentials, AdminClient};
use inertia_client::Client;
use inertia_protocol::admin::{AdminErrorKind, AdminRequest, AdminResponse, StatusReport};
use inertia_protocol::EntityId;
use inertia_server::server::RunningServer;

/// An admin connection to a dev-mode `server` with its admin credential
/// (operator "e2e").
pub async fn admin(server: &RunningServer) -> AdminClient {
    let fingerprint = read_credentials(server.credentials_path().expect("dev mode"))
        .expect("dev credentials")
        .fingerprint()
        .expect("fingerprint");
    AdminClient::connect(server.addr(), fingerprint, server.admin_token(), "e2e")
        .await
        .expect("the admin credential is accepted")
}

/// The answer to `request` (the connection must hold).
pub async fn call(admin: &mut AdminClient, request: AdminRequest) -> AdminResponse {
    admin.call(request).await.expect("an answer")
}

/// Asserts that `request` is answered `Ok`.
pub async fn ok(admin: &mut AdminClient, request: AdminRequest) {
    let what = format!("{request:?}");
    assert_eq!(call(admin, request).await, AdminResponse::Ok, "{what}");
}

/// The server's status.
pub async fn status(admin: &mut AdminClient) -> StatusReport {
    match call(admin, AdminRequest::Status).await {
        AdminResponse::Status(s) => s,
        other => panic!("expected a status, got {other:?}"),
    }
}

/// The kind of error `request` is answered with (it must be refused).
pub async fn error_kind(admin: &mut AdminClient, request: AdminRequest) -> AdminErrorKind {
    let what = format!("{request:?}");
    match call(admin, request).await {
        AdminResponse::Error(e) => e.kind,
        other => panic!("{what}: expected an error, got {other:?}"),
    }
}

/// Waits (up to `limit`) for `cond`; whether it came true.
pub async fn wait_for<F: Future<Output = bool>>(
    limit: Duration,
    mut cond: impl FnMut() -> F,
) -> bool {
    let deadline = Instant::now() + limit;
    while Instant::now() < deadline {
        if cond().await {
            return true;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    cond().await
}

/// The ids of the entities the client was told about under `names`.
pub fn ids_named(client: &Client, names: &[&str]) -> Vec<EntityId> {
    let entities = client.entities();
    names
        .iter()
        .map(|n| {
            entities
                .iter()
                .find(|e| e.name == *n)
                .unwrap_or_else(|| panic!("entity {n} was described"))
                .id
        })
        .collect()
}
