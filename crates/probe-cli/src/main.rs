//! The `probes` command.
fn main() {}
