//! `rift`: the command-line program. Parses arguments and wires rift-fx and rift-render together;
//! everything else lives in the library crates.

mod bench;
mod cli;
mod farm;
mod fx_cmd;
mod layout;
mod looks_cmd;
mod memory;
mod merge_cmd;
mod plot;
/// Refuses, before anything runs, a processor without what the build targets.
mod processor;
mod progress;
mod render_cmd;
mod resume;
mod reveal_cmd;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Portal effects and a portal-aware path tracer.
#[derive(Parser)]
#[command(name = "rift", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate portal rings for a shot and write them as USD, PLY and ring caches.
    Fx(fx_cmd::FxArgs),
    /// List the ring look presets, and draw them as a contact sheet (`--contact-sheet PNG`).
    Looks(looks_cmd::LooksArgs),
    /// Render frames of a shot to EXR with the path tracer.
    Render(render_cmd::RenderArgs),
    /// Merge parts of one frame (sample ranges, windows) into the image one render makes.
    Merge(merge_cmd::MergeArgs),
    /// Write a farm job for a shot: frames split in sample chunks, rendered, merged.
    #[command(subcommand)]
    Farm(farm::FarmCommand),
    /// Measure performance and print tables.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// Stage a shot in the browser: a local server showing it from its camera and an orbit
    /// view, at any frame.
    Layout(layout::LayoutArgs),
    /// What each opening shows over a range of frames: the objects seen through it and their
    /// share of the image, marking those the camera sees only through openings.
    Reveal(reveal_cmd::RevealArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Fx(args) => fx_cmd::run(args),
        Command::Looks(args) => looks_cmd::run(args),
        Command::Render(args) => render_cmd::run(args),
        Command::Merge(args) => merge_cmd::run(args),
        Command::Farm(cmd) => farm::run(cmd),
        Command::Bench(cmd) => bench::run(cmd),
        Command::Layout(args) => layout::run(args),
        Command::Reveal(args) => reveal_cmd::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => match e.downcast_ref::<resume::Interrupted>() {
            Some(stopped) => {
                eprintln!("rift: {stopped}");
                ExitCode::from(stopped.exit_code())
            }
            None => {
                eprintln!("rift: error: {e:#}");
                ExitCode::FAILURE
            }
        },
    }
}
