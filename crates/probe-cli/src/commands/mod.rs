//! One module per `probes` subcommand.

pub mod bake;
pub mod bake_merge;
pub mod demo;
pub mod eval;
pub mod index;
pub mod place;
pub mod reference;
pub mod render;
pub mod scene_info;
