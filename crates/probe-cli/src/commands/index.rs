//! `probes index`: Delaunay tetrahedralization, edge-cast probes, nearest-probe tree,
//! Voronoi-sphere neighbour maps and the sparse voxel octree of best probes.

use crate::cli_error::CliError;
use crate::output::Report;
use crate::progress::spinner;
use crate::spec::{open_scene, probe_set};
use probe_index::{EdgeCastOptions, IndexOptions, IndexReport, ProbeIndex, SvoOptions};
use serde_json::{Value, json};
use std::time::Instant;

/// Arguments of `probes index`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A glTF 2.0 file or `builtin:NAME`.
    pub scene: String,
    /// Probe positions: a `probes/1` JSON file or `grid:NXxNYxNZ`.
    #[arg(long)]
    pub probes: String,
    /// Depth of the sparse voxel octree (its finest voxel is the scene cube / 2^depth), 1..=15;
    /// 0 skips the octree.
    #[arg(long, default_value_t = 7)]
    pub svo_depth: u32,
    /// Texels per side of the Voronoi-sphere neighbour maps.
    #[arg(long, default_value_t = 16)]
    pub neighbour_resolution: u32,
    /// Skip seed 002's edge ray casts (which insert probes where geometry cuts a Delaunay edge).
    #[arg(long)]
    pub no_edge_casts: bool,
    /// Seed of the octree's random visibility samples.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

/// Builds every index structure and reports counts, bytes and times.
pub fn run(args: &Args) -> Result<Box<dyn Report>, CliError> {
    let scene = open_scene(&args.scene)?;
    let probes = probe_set(&args.probes, &scene)?;
    let options = IndexOptions {
        edge_casts: (!args.no_edge_casts).then(EdgeCastOptions::default),
        neighbour_resolution: args.neighbour_resolution,
        svo: (args.svo_depth > 0).then(|| SvoOptions {
            max_depth: args.svo_depth,
            seed: args.seed,
            ..SvoOptions::default()
        }),
    };
    let progress = spinner("indexing");
    let start = Instant::now();
    let result = ProbeIndex::build(&probes.positions, &scene, &options);
    progress.finish_and_clear();
    let (_, report) = result?;
    Ok(Box::new(IndexSummary {
        scene: scene.name().to_owned(),
        report,
        seconds: start.elapsed().as_secs_f64(),
    }))
}

struct IndexSummary {
    scene: String,
    report: IndexReport,
    seconds: f64,
}

impl Report for IndexSummary {
    fn json(&self) -> Value {
        let r = &self.report;
        let svo = r.svo.as_ref().map(|s| {
            json!({
                "finest_voxel_size": s.finest_voxel_size,
                "surface_leaves": s.surface_leaves,
                "empty_leaves": s.empty_leaves,
                "leaves_without_probe": s.leaves_without_probe,
                "nodes": s.nodes,
                "blocks": s.blocks,
                "payloads": s.payloads,
                "bytes": s.bytes,
                "full_tree_bytes": s.full_bytes,
                "seconds": r.svo_time.as_secs_f64(),
            })
        });
        json!({
            "command": "index",
            "scene": self.scene,
            "probes_given": r.probes_given,
            "probes_added_by_edge_casts": r.probes_added,
            "edge_rays": r.edge_rays,
            "duplicates": r.duplicates,
            "tetrahedra": r.tetrahedra,
            "hull_faces": r.hull_faces,
            "delaunay_skipped": r.delaunay_skipped.map(|why| why.to_string()),
            "bytes": {
                "tetrahedra": r.tetrahedra_bytes,
                "nearest_tree": r.nearest_bytes,
                "voronoi_neighbours": r.neighbour_bytes,
                "svo": r.svo.as_ref().map(|s| s.bytes),
            },
            "seconds": {
                "delaunay": r.delaunay_time.as_secs_f64(),
                "edge_casts": r.edge_cast_time.as_secs_f64(),
                "nearest_tree": r.nearest_time.as_secs_f64(),
                "voronoi_neighbours": r.neighbour_time.as_secs_f64(),
                "svo": r.svo_time.as_secs_f64(),
                "total": self.seconds,
            },
            "svo": svo,
        })
    }

    fn text(&self) -> String {
        format!(
            "scene: {}\n{}total: {:.3} s\n",
            self.scene, self.report, self.seconds
        )
    }
}
