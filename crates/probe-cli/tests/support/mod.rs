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

/// Asserts that `output` is a refusal: a failed run whose error is one line naming `needle`.
#[allow(
    dead_code,
    reason = "each test binary compiles this module; not every one has a refusal"
)]
pub fn assert_refused_in_one_line(output: &Output, needle: &str) {
    let message = stderr(output);
    assert!(!output.status.success(), "accepted: {message}");
    assert_eq!(message.trim().lines().count(), 1, "{message}");
    assert!(message.contains(needle), "{message}");
}
