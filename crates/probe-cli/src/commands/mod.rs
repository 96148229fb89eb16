//! One module per `probes` subcommand.

pub mod scene_info;
