//! Runs the `rodlog` binary under test.

use std::process::{Command, Output};

/// Runs `rodlog ARGS` from the repository root (where the tests' relative paths point) and
/// returns its output, whatever its exit status.
///
/// # Panics
/// When the binary cannot be started.
pub fn rodlog(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .expect("run rodlog")
}
