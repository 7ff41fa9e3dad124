//! How an operator's `kick` reaches a connected client: each joined game
//! connection leaves a way to tell it to go, by client id.

use std::collections::BTreeMap;
use std::sync::Mutex;

use tokio::sync::oneshot;

/// The connected clients an operator may kick, by client id: the number of
/// the connection that holds the client, and where its reason goes.
#[derive(Debug, Default)]
pub struct Kicks {
    by_client: Mutex<BTreeMap<u64, (u64, oneshot::Sender<String>)>>,
}

impl Kicks {
    /// Client `client` joined on connection `connection`: the reason of a
    /// kick comes out of the receiver. A client already held (the same id
    /// on another connection) is replaced.
    pub fn admit(&self, client: u64, connection: u64) -> oneshot::Receiver<String> {
        let (tx, rx) = oneshot::channel();
        self.lock().insert(client, (connection, tx));
        rx
    }

    /// Connection `connection` no longer holds client `client` (a later
    /// connection's hold on the same id stays).
    pub fn forget(&self, client: u64, connection: u64) {
        let mut by_client = self.lock();
        if by_client.get(&client).map(|(c, _)| *c) == Some(connection) {
            by_client.remove(&client);
        }
    }

    /// Tells client `client` to leave with `reason`; false when it is not
    /// connected (or its connection is already ending).
    pub fn kick(&self, client: u64, reason: String) -> bool {
        match self.lock().remove(&client) {
            Some((_, tx)) => tx.send(reason).is_ok(),
            None => false,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, BTreeMap<u64, (u64, oneshot::Sender<String>)>> {
        self.by_client.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kick_reaches_the_connection_that_holds_the_client() {
        let kicks = Kicks::default();
        let mut first = kicks.admit(7, 1);
        let mut second = kicks.admit(7, 2);
        // The first connection's hold was replaced; forgetting it leaves
        // the second's.
        kicks.forget(7, 1);
        assert!(kicks.kick(7, String::from("bye")));
        assert_eq!(second.try_recv().as_deref(), Ok("bye"));
        assert!(first.try_recv().is_err());
        assert!(
            !kicks.kick(7, String::from("again")),
            "a kick is taken once"
        );
        assert!(!kicks.kick(8, String::from("nobody")));
    }
}
