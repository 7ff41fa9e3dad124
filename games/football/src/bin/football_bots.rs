//! Bots for a football server, to play against or to watch:
//!
//! ```text
//! cargo run --release -p inertia-football --bin football-bots -- [--bots N] [--server ADDR] [--credentials FILE]
//! ```
//!
//! Each bot joins with a token from the dev credentials a dev-mode server
//! writes, and plays until the match is over or the process is stopped,
//! printing each goal and the result.

use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use inertia_client::{dev, Client, ClientEvent};
use inertia_football::bot::{view_of, Bot};
use inertia_football::Tell;

#[derive(Debug, Parser)]
#[command(about = "Bots that play football on an Inertia football server")]
struct Args {
    #[command(flatten)]
    dev: dev::DevArgs,
    /// How many bots join (they fill the smaller team first).
    #[arg(long, default_value_t = 3)]
    bots: usize,
}

/// One bot's life: join, play a tick at a time, report what it is told.
async fn play(args: dev::DevArgs, speaker: bool) -> Result<(), String> {
    let (found, token, _) = dev::dev_token(&args.credentials, None).map_err(|e| e.to_string())?;
    let addr = args.server.unwrap_or(found);
    let client = Client::connect(addr, &token)
        .await
        .map_err(|e| format!("joining {addr}: {e}"))?;
    let tick = Duration::from_secs_f64(1.0 / f64::from(client.server_info().tick_hz));
    let mut bot = Bot::new();
    let mut every = tokio::time::interval(tick);
    loop {
        every.tick().await;
        while let Some(event) = client.poll_event() {
            match (event.message::<Tell>(), &event) {
                (Some(Ok(tell)), _) if speaker => match tell {
                    Tell::Goal { team, score, .. } => {
                        println!(
                            "goal for {}: red {} – blue {}",
                            team.name(),
                            score[0],
                            score[1]
                        );
                    }
                    Tell::Over { winner, score } => {
                        println!(
                            "{} wins, red {} – blue {}",
                            winner.name(),
                            score[0],
                            score[1]
                        );
                    }
                    _ => {}
                },
                (_, ClientEvent::Disconnected(why)) => {
                    if speaker {
                        println!("left: {why:?}");
                    }
                    return Ok(());
                }
                _ => {}
            }
        }
        if let Some(view) = view_of(&client) {
            let _ = client.set_game_input(&bot.play(&view));
        }
    }
}

#[tokio::main]
async fn main() -> ExitCode {
    let args = Args::parse();
    let bots = (0..args.bots).map(|k| tokio::spawn(play(args.dev.clone(), k == 0)));
    let mut failed = false;
    for bot in bots.collect::<Vec<_>>() {
        match bot.await {
            Ok(Ok(())) => {}
            Ok(Err(why)) => {
                eprintln!("football-bots: {why}");
                failed = true;
            }
            Err(e) => {
                eprintln!("football-bots: a bot failed: {e}");
                failed = true;
            }
        }
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
