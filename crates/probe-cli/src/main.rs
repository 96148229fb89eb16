//! `probes`: place, bake, index, render, evaluate and chart light-field probes.
//!
//! A thin binary over the workspace crates. Every command takes `--json` to print its result
//! as one JSON object on stdout; errors go to stderr as one line and the exit status is
//! non-zero. Long work shows progress bars on stderr (only when stderr is a terminal).

mod cli_error;
mod commands;
mod output;
mod progress;
mod spec;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Place, bake, index and trace light-field (radiance) probes.
#[derive(Parser, Debug)]
#[command(name = "probes", version, about, long_about = None)]
struct Cli {
    /// Print the result as one JSON object on stdout instead of text.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Summarise a scene: triangles, bounds, materials, lights, cameras and load warnings.
    SceneInfo(commands::scene_info::Args),
    /// Build the probe indexes: Delaunay, edge-cast probes, Voronoi neighbours, octree.
    Index(commands::index::Args),
    /// Bake light-field probes (radiance, normals, radial distance, derived maps).
    Bake(commands::bake::Args),
    /// Join the partial bakes of `bake --shard K/N` into the whole bake (byte for byte).
    BakeMerge(commands::bake_merge::Args),
    /// Render the path-traced reference (direct, one-bounce glossy, or full GI).
    Reference(commands::reference::Args),
    /// Place probes automatically (grid, relocated grid, SDF, medial axis, seed 002, minimal).
    Place(commands::place::Args),
    /// Render a camera through a bake's probes (glossy: GPU light-field trace; diffuse).
    Render(commands::render::Args),
    /// Place, bake, index and trace on the built-in Cornell box; compare with the path tracer.
    Demo(commands::demo::Args),
    /// The speed-against-accuracy sweep: report, CSV, JSON and charts.
    Eval(commands::eval::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::SceneInfo(args) => commands::scene_info::run(args),
        Command::Index(args) => commands::index::run(args),
        Command::Bake(args) => commands::bake::run(args),
        Command::BakeMerge(args) => commands::bake_merge::run(args),
        Command::Reference(args) => commands::reference::run(args),
        Command::Place(args) => commands::place::run(args),
        Command::Render(args) => commands::render::run(args),
        Command::Demo(args) => commands::demo::run(args),
        Command::Eval(args) => commands::eval::run(args),
    };
    match result {
        Ok(report) => {
            output::print(&*report, cli.json);
            ExitCode::SUCCESS
        }
        Err(error) => {
            eprintln!("probes: error: {}", cli_error::one_line(&error));
            ExitCode::FAILURE
        }
    }
}
