//! Why an entity left the world without the rules asking: what the
//! simulation tells the rules ([`GameRules::on_removed`](super::GameRules::on_removed)).

/// Why something happened to an entity without anyone asking.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RemovalReason {
    /// It left the world bounds.
    OutOfBounds,
    /// Its state went non-finite.
    Quarantined,
    /// An operator removed it.
    Despawned,
}
