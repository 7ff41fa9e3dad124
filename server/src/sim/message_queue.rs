//! Clients' messages waiting for the next tick.
//!
//! A message that arrives between ticks is held here and handed to the
//! rules at the start of the next live tick, before that tick's inputs:
//! every client's in ascending client id, each client's in the order its
//! connection took them (the order it sent its reliable messages). That
//! order depends on nothing the network did across clients, and the
//! journal keeps it, so a replay hands the rules the same messages in the
//! same order at the same tick.
//!
//! Each client's connection already bounds its rate; here at most
//! [`MAX_WAITING_MESSAGES`] wait per client (a paused clock takes no
//! ticks), and more are refused and counted.

use std::collections::{BTreeMap, VecDeque};

use inertia_protocol::connection::ReceivedMessage;
use inertia_protocol::message::MessageRefusal;

use crate::rules::ClientId;

/// The most messages one client may have waiting for a tick.
pub const MAX_WAITING_MESSAGES: usize = 256;

/// Every client's messages waiting for the next tick.
#[derive(Debug, Clone, Default)]
pub struct MessageQueue {
    clients: BTreeMap<ClientId, VecDeque<ReceivedMessage>>,
}

impl MessageQueue {
    /// Holds `message` of `client` for the next tick, or refuses it when
    /// [`MAX_WAITING_MESSAGES`] of the client's wait already.
    pub fn offer(
        &mut self,
        client: ClientId,
        message: ReceivedMessage,
    ) -> Result<(), MessageRefusal> {
        let waiting = self.clients.entry(client).or_default();
        if waiting.len() >= MAX_WAITING_MESSAGES {
            return Err(MessageRefusal::Backlog {
                max: MAX_WAITING_MESSAGES,
            });
        }
        waiting.push_back(message);
        Ok(())
    }

    /// Every waiting message, in the order the rules get them (by client
    /// id, then as taken), leaving the queue empty.
    pub fn take_all(&mut self) -> Vec<(ClientId, ReceivedMessage)> {
        std::mem::take(&mut self.clients)
            .into_iter()
            .flat_map(|(client, waiting)| waiting.into_iter().map(move |m| (client, m)))
            .collect()
    }

    /// Drops what `client` has waiting (it left).
    pub fn forget(&mut self, client: ClientId) {
        self.clients.remove(&client);
    }

    /// Whether nothing waits.
    pub fn is_empty(&self) -> bool {
        self.clients.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use inertia_protocol::message::Delivery;

    use super::*;

    fn msg(b: u8) -> ReceivedMessage {
        ReceivedMessage {
            delivery: Delivery::Reliable,
            bytes: vec![b],
        }
    }

    #[test]
    fn messages_come_out_by_client_then_as_taken_whatever_order_they_came_in() {
        let mut q = MessageQueue::default();
        for (client, b) in [(9, 1), (2, 2), (9, 3), (5, 4), (2, 5)] {
            q.offer(client, msg(b)).unwrap();
        }
        let order: Vec<(ClientId, u8)> = q
            .take_all()
            .into_iter()
            .map(|(c, m)| (c, m.bytes[0]))
            .collect();
        assert_eq!(order, [(2, 2), (2, 5), (5, 4), (9, 1), (9, 3)]);
        assert!(q.is_empty());
    }

    #[test]
    fn a_backlog_is_refused_and_a_client_that_left_has_its_messages_dropped() {
        let mut q = MessageQueue::default();
        for _ in 0..MAX_WAITING_MESSAGES {
            q.offer(1, msg(0)).unwrap();
        }
        assert_eq!(
            q.offer(1, msg(0)),
            Err(MessageRefusal::Backlog {
                max: MAX_WAITING_MESSAGES
            })
        );
        q.offer(2, msg(7)).unwrap();
        q.forget(1);
        assert_eq!(q.take_all().len(), 1);
    }
}
