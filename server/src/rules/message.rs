//! The game's messages to its clients, as the rules send them: to whom
//! ([`Recipients`]), how ([`Delivery`]) and what (the game's bytes, at
//! most [`MAX_MESSAGE_BYTES`]).
//!
//! A message sent during a tick leaves with the frame of that tick, as
//! the catalog's spawns and despawns do: a reliable one on each
//! recipient's control stream, after the spawns of its slot (so it may
//! name an entity spawned in the same tick), an unreliable one in a
//! datagram of its own just before the slot's snapshot. A recipient that
//! is not connected when its slot comes gets nothing.
//!
//! [`MAX_MESSAGE_BYTES`]: inertia_protocol::message::MAX_MESSAGE_BYTES

use std::sync::Arc;

use inertia_protocol::message::Delivery;

use super::ClientId;

/// Who a message is for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Recipients {
    /// Every connected client.
    All,
    /// One client.
    One(ClientId),
    /// These clients (ascending, each once).
    Some(Arc<[ClientId]>),
    /// Every connected client but this one.
    AllBut(ClientId),
}

impl Recipients {
    /// These clients, in any order, repeats allowed.
    pub fn some(clients: impl IntoIterator<Item = ClientId>) -> Self {
        let mut clients: Vec<ClientId> = clients.into_iter().collect();
        clients.sort_unstable();
        clients.dedup();
        Recipients::Some(clients.into())
    }

    /// Whether `client` is one of them.
    pub fn includes(&self, client: ClientId) -> bool {
        match self {
            Recipients::All => true,
            Recipients::One(c) => *c == client,
            Recipients::Some(clients) => clients.binary_search(&client).is_ok(),
            Recipients::AllBut(c) => *c != client,
        }
    }
}

/// A message the rules sent, on its way to its recipients.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutgoingMessage {
    /// Who it is for.
    pub to: Recipients,
    /// How it travels.
    pub delivery: Delivery,
    /// The game's bytes.
    pub bytes: Vec<u8>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recipients_include_whom_they_name() {
        let some = Recipients::some([5, 1, 5, 3]);
        assert_eq!(some, Recipients::Some(vec![1, 3, 5].into()));
        assert!(some.includes(3) && !some.includes(2));
        assert!(Recipients::All.includes(9));
        assert!(Recipients::One(4).includes(4) && !Recipients::One(4).includes(5));
        assert!(!Recipients::AllBut(4).includes(4) && Recipients::AllBut(4).includes(5));
    }

    #[test]
    fn every_message_refusal_has_a_label_the_metrics_forget() {
        use inertia_protocol::message::{MessageDecodeError, MessageRefusal};
        // A client's series are removed by these labels when it leaves: a
        // reason missing from the list would pile up.
        for refusal in [
            MessageRefusal::TooLong { len: 2, max: 1 },
            MessageRefusal::RateLimited {
                per_second: 1,
                bytes_per_second: 1,
            },
            MessageRefusal::Malformed,
            MessageRefusal::NotConnected,
            MessageRefusal::Backlog { max: 1 },
            MessageRefusal::Undecodable(MessageDecodeError::Truncated),
            MessageRefusal::Rules("no".into()),
        ] {
            assert!(crate::metrics::MESSAGE_REFUSAL_REASONS.contains(&refusal.reason()));
        }
    }
}
