//! What the command-line tests share: running the `probes` binary and reading its errors.

use std::process::{Command, Output};

/// Runs the `probes` binary with `args` and waits for it. Without `XDG_RUNTIME_DIR`, Mesa
/// writes a warning to stderr on every adapter query; the temporary folder stands in, so a
/// test that counts the lines of an error sees only the binary's own.
pub fn probes(args: &[&str]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_probes"));
    command.args(args);
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        command.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    command.output().expect("the probes binary runs")
}

/// The binary's stderr as text.
pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}
