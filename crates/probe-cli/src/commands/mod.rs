//! One module per `probes` subcommand.

pub mod index;
pub mod scene_info;
