//! The last words on a control stream, on either side: what waits is
//! written until one deadline, then the stream is finished and the peer
//! has until another to take it, and then the connection closes.

use std::time::{Duration, Instant};

/// Where the last words are.
#[derive(Debug, Clone, Copy)]
pub(crate) enum LastWords {
    /// Writing what waits, until `deadline`.
    Flushing { deadline: Instant },
    /// The stream is to be finished (`finished` once it was), and taken by
    /// the peer until `deadline`.
    Finishing { deadline: Instant, finished: bool },
}

impl LastWords {
    /// Writing from `now`, for at most `wait`.
    pub(crate) fn flushing(now: Instant, wait: Duration) -> LastWords {
        LastWords::Flushing {
            deadline: now + wait,
        }
    }

    /// Finishing from `now`, the peer given `wait` to take the stream.
    pub(crate) fn finishing(now: Instant, wait: Duration) -> LastWords {
        LastWords::Finishing {
            deadline: now + wait,
            finished: false,
        }
    }

    /// When this phase ends.
    pub(crate) fn deadline(&self) -> Instant {
        match *self {
            LastWords::Flushing { deadline } | LastWords::Finishing { deadline, .. } => deadline,
        }
    }

    /// True while what waits is being written.
    pub(crate) fn is_flushing(&self) -> bool {
        matches!(self, LastWords::Flushing { .. })
    }

    /// True when the stream should be finished now.
    pub(crate) fn wants_finish(&self) -> bool {
        matches!(
            self,
            LastWords::Finishing {
                finished: false,
                ..
            }
        )
    }

    /// True while the finished stream waits to be taken.
    pub(crate) fn awaits_finish(&self) -> bool {
        matches!(self, LastWords::Finishing { finished: true, .. })
    }

    /// The stream was finished.
    pub(crate) fn finish_sent(&mut self) {
        if let LastWords::Finishing { finished, .. } = self {
            *finished = true;
        }
    }
}
