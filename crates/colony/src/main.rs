//! The `colony` command: each subcommand is a thin call into a library crate.
#![forbid(unsafe_code)]

mod cmd;

use std::io::IsTerminal as _;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// colony: a toolkit for multi-robot systems.
#[derive(Parser)]
#[command(name = "colony", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a hub, the simulated swarm sorting live, and the monitor in the browser.
    Demo(cmd::demo::Args),
    /// Run the hub (the broker every colony process talks through).
    Hub(cmd::hub::Args),
    /// Publish one packet (or packets read from standard input).
    Pub(cmd::pubsub::PubArgs),
    /// Subscribe and print packets as they arrive.
    Sub(cmd::pubsub::SubArgs),
    /// Call a service and print its answer (request and reply over the hub).
    Call(cmd::rpc::CallArgs),
    /// Provide a service: answer each call by running a command (or echo it).
    Serve(cmd::rpc::ServeArgs),
    /// Serve the system monitor: the arena, the hub and operator override in a browser.
    Monitor(cmd::monitor::Args),
    /// Share this hub's channels with hubs of other sites, over Zenoh.
    Bridge(cmd::bridge::Args),
    /// Ask the hub for its clients, channels and drops.
    Status(cmd::status::Args),
    /// Watch a live hub (or a traffic log) in the terminal, channel by channel, field by field.
    Spy(cmd::spy::Args),
    /// List a traffic log (.clog or MCAP), filtered by channel and time; export it as MCAP; recover a torn MCAP.
    Log(cmd::traffic::LogCommand),
    /// Publish a traffic log again with its original timing.
    Replay(cmd::traffic::ReplayArgs),
    /// Swarm sorting: experiments, the paper's reproduction, live mode.
    #[command(subcommand)]
    Sort(cmd::sort::SortCommand),
    /// The strategy game: Capture the Flag and Death Match, live or fast-forwarded.
    #[command(subcommand)]
    Game(cmd::game::GameCommand),
    /// Run a Moving AI path-finding benchmark scenario and check every length.
    Path(cmd::path::Args),
    /// MURDOCH task allocation: live demo, the paper's two experiments, greedy vs optimal.
    #[command(subcommand)]
    Tasks(cmd::tasks::TasksCommand),
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("COLONY_LOG")
                .unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
        // Colour codes only to a person at a terminal: in a file or a pipe
        // they are noise that every reader has to strip. NO_COLOR (no-color.org)
        // turns them off there too.
        .with_ansi(
            std::io::stderr().is_terminal()
                && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty()),
        )
        .init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(a) => cmd::demo::run(a),
        Command::Hub(a) => cmd::hub::run(a),
        Command::Pub(a) => cmd::pubsub::publish(a),
        Command::Sub(a) => cmd::pubsub::subscribe(a),
        Command::Call(a) => cmd::rpc::call(a),
        Command::Serve(a) => cmd::rpc::serve(a),
        Command::Monitor(a) => cmd::monitor::run(a),
        Command::Bridge(a) => cmd::bridge::run(a),
        Command::Status(a) => cmd::status::run(a),
        Command::Spy(a) => cmd::spy::run(a),
        Command::Log(a) => cmd::traffic::run(a),
        Command::Replay(a) => cmd::traffic::replay(a),
        Command::Sort(c) => cmd::sort::run(c),
        Command::Game(c) => cmd::game::run(c),
        Command::Path(a) => cmd::path::run(a),
        Command::Tasks(c) => cmd::tasks::run(c),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // A reader that stopped early (`colony path ... | head`) is not an
        // error of ours: end quietly, as other command-line tools do.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            // Every error either prints its source or returns it (never
            // both), so the chain, `: `-separated, says each thing once.
            eprintln!("colony: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
