//! The football server: the game's rules in the whole `inertia-server`
//! process (every option, dev mode with no arguments, signals, Agones,
//! recording, the admin RPC, metrics), on the game's pitch unless
//! `--scene` names another.

use std::process::ExitCode;

use inertia_football::{FootballRules, PITCH};
use inertia_server::process::Game;

// The allocator the server's figures are measured with.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    Game::new(|_config| Box::new(FootballRules::default()))
        .default_scene(PITCH)
        .run()
}
