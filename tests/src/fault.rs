//! Rules with an injected fault, to see what operators and clients see when
//! a simulation fails: [`FaultRules`] plays the sandbox game and panics in
//! a tick a set number of ticks after the first client joined.

use inertia_protocol::{EntityId, PlayerInput};
use inertia_server::rules::{
    ClientId, GameRules, InputRefusal, JoinRefusal, RemovalReason, SandboxRules, SandboxSettings,
    SimContext,
};

/// The sandbox rules, failing `after` ticks after the first join.
#[derive(Debug)]
pub struct FaultRules {
    inner: SandboxRules,
    after: u64,
    joined_at: Option<u64>,
}

impl FaultRules {
    /// Rules that panic in the tick `after` ticks after the first join.
    pub fn new(after: u64) -> FaultRules {
        FaultRules {
            inner: SandboxRules::new(SandboxSettings::default()),
            after,
            joined_at: None,
        }
    }
}

impl GameRules for FaultRules {
    fn input_bytes(&self) -> usize {
        self.inner.input_bytes()
    }
    fn on_connect(
        &mut self,
        client: ClientId,
        ctx: &mut SimContext<'_>,
    ) -> Result<EntityId, JoinRefusal> {
        self.joined_at.get_or_insert(ctx.tick());
        self.inner.on_connect(client, ctx)
    }

    fn on_disconnect(&mut self, client: ClientId, ctx: &mut SimContext<'_>) {
        self.inner.on_disconnect(client, ctx);
    }

    fn on_input(
        &mut self,
        client: ClientId,
        input: &PlayerInput,
        ctx: &mut SimContext<'_>,
    ) -> Result<(), InputRefusal> {
        self.inner.on_input(client, input, ctx)
    }

    fn before_tick(&mut self, ctx: &mut SimContext<'_>) {
        if let Some(t) = self.joined_at {
            if ctx.tick() >= t + self.after {
                panic!("injected fault at tick {}", ctx.tick());
            }
        }
        self.inner.before_tick(ctx);
    }

    fn after_tick(&mut self, ctx: &mut SimContext<'_>) {
        self.inner.after_tick(ctx);
    }

    fn on_removed(&mut self, entity: EntityId, reason: RemovalReason, ctx: &mut SimContext<'_>) {
        self.inner.on_removed(entity, reason, ctx);
    }
}
