//! Players' replays of the recent past, beside the live match (the wire
//! is [`inertia_protocol::replay`]).
//!
//! The snapshot stage keeps the live frames it served
//! ([`window::ReplayWindow`]) and, once a slot after its live clients,
//! plays each replay a client asked for from them ([`desk::ReplayDesk`]):
//! off the tick thread, with what is left of the slot's time, through the
//! same codec, interest and budget as live snapshots but on a session of
//! the replay's own. A client's connection task hands its asks and its
//! acknowledgements of replay snapshots to the stage through its
//! [`ReplayMailbox`].

pub mod desk;
pub mod window;

use std::sync::Mutex;

use inertia_protocol::replay::ReplayAsk;

pub use desk::{DeskOutput, ReplayDesk, ReplayLimits};
pub use window::ReplayWindow;

/// Asks a mailbox holds at most between two slots: the connection's rate
/// limit keeps requests far below, and cancels beyond it change nothing.
const MAX_ASKS: usize = 8;
/// Acknowledgements a mailbox holds at most between two slots.
const MAX_ACKS: usize = 64;

/// What a client's connection task leaves for the snapshot stage about
/// its replays.
#[derive(Debug, Default)]
pub struct ReplayMailbox {
    asks: Mutex<Vec<ReplayAsk>>,
    acks: Mutex<Vec<(u16, u16)>>,
}

impl ReplayMailbox {
    /// The client asked `ask` (checked by its connection).
    pub fn ask(&self, ask: ReplayAsk) {
        if let Ok(mut asks) = self.asks.lock() {
            if asks.len() >= MAX_ASKS {
                asks.remove(0);
            }
            asks.push(ask);
        }
    }

    /// The client acknowledged replay `replay`'s snapshot `sequence`.
    pub fn ack(&self, replay: u16, sequence: u16) {
        if let Ok(mut acks) = self.acks.lock() {
            if acks.len() >= MAX_ACKS {
                acks.remove(0);
            }
            acks.push((replay, sequence));
        }
    }

    /// Takes the asks waiting, in arrival order.
    pub fn take_asks(&self) -> Vec<ReplayAsk> {
        self.asks
            .lock()
            .map(|mut a| std::mem::take(&mut *a))
            .unwrap_or_default()
    }

    /// Takes the acknowledgements waiting, in arrival order.
    pub fn take_acks(&self) -> Vec<(u16, u16)> {
        self.acks
            .lock()
            .map(|mut a| std::mem::take(&mut *a))
            .unwrap_or_default()
    }
}
