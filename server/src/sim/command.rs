//! What the tick thread is asked to do, and the one place it does it:
//! [`Simulation::apply`].

use tokio::sync::oneshot;

use super::clock_control::ClockControl;
use super::Simulation;
use crate::rules::{ClientId, JoinRefusal};
use inertia_protocol::connection::ReceivedMessage;
use inertia_protocol::{EntityId, PlayerInput};

/// Where a client that joined starts: its avatar, and the first of the
/// rules' messages that is news to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JoinedAt {
    /// Its avatar.
    pub avatar: EntityId,
    /// The number the first message the rules sent from its join on gets
    /// ([`RecentMessage::number`](super::RecentMessage::number)): what its
    /// join made the rules say (a welcome, its team) is news to it,
    /// nothing before.
    pub first_message: u64,
}

/// What a client sent that goes through the input channel.
#[derive(Debug, Clone)]
pub enum FromClient {
    /// An input, for its tick.
    Input(PlayerInput),
    /// A message, for the next tick.
    Message(ReceivedMessage),
}

/// A command to the tick thread.
#[derive(Debug)]
pub enum Command {
    /// A client joins; the reply carries its avatar or the refusal.
    Join {
        /// The client.
        client: ClientId,
        /// Where the answer goes.
        reply: oneshot::Sender<Result<JoinedAt, JoinRefusal>>,
    },
    /// A client left.
    Leave {
        /// The client.
        client: ClientId,
    },
    /// A client's input (goes through the input channel).
    Input {
        /// The client.
        client: ClientId,
        /// What it asks.
        input: PlayerInput,
    },
    /// A client's message (goes through the input channel).
    Message {
        /// The client.
        client: ClientId,
        /// What it says.
        message: ReceivedMessage,
    },
    /// Pause, resume, speed, step or run-to ([`Simulation::control_clock`]).
    Clock(ClockControl),
    /// Run a function on the tick thread, between ticks (the admin channel
    /// reads and edits the world this way).
    Call(SimCall),
    /// Stop the thread after publishing a last frame.
    Shutdown,
}

/// A function run on the tick thread with the [`Simulation`], between
/// ticks ([`SimHandle::call`]).
pub struct SimCall(pub Box<dyn FnOnce(&mut Simulation) + Send>);

impl std::fmt::Debug for SimCall {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SimCall")
    }
}

/// Why a command was not delivered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum CommandError {
    /// The channel is full: the tick thread is behind. Dropped; retry later.
    #[error("the simulation is busy; command dropped")]
    Busy,
    /// The tick thread has stopped.
    #[error("the simulation has stopped")]
    Stopped,
}

impl Simulation {
    /// Takes what a client sent through the input channel.
    pub fn take_from_client(&mut self, client: ClientId, sent: FromClient) {
        match sent {
            FromClient::Input(input) => {
                let _ = self.input(client, &input);
            }
            FromClient::Message(message) => {
                let _ = self.message(client, message);
            }
        }
    }

    /// Applies one command; false for [`Command::Shutdown`].
    pub fn apply(&mut self, cmd: Command) -> bool {
        match cmd {
            Command::Join { client, reply } => {
                let first_message = self.next_message_number();
                let r = self.join(client).map(|avatar| JoinedAt {
                    avatar,
                    first_message,
                });
                // The asker may have given up; the avatar stays until Leave.
                let _ = reply.send(r);
            }
            Command::Leave { client } => self.leave(client),
            Command::Input { client, input } => {
                let _ = self.input(client, &input);
            }
            Command::Message { client, message } => {
                let _ = self.message(client, message);
            }
            Command::Clock(request) => {
                if let Err(e) = self.control_clock(request) {
                    tracing::warn!(error = %e, ?request, "clock request refused");
                }
            }
            Command::Call(SimCall(f)) => f(self),
            Command::Shutdown => return false,
        }
        true
    }
}
