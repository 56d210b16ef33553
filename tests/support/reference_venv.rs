//! The throw-away Python venv of `scripts/venv.sh` (OpenCV, rerun-sdk, the ROS 2 decoders)
//! that the interop and peer tests run: `RODLOG_REF_VENV`, default `<repo>/.venv-ref`.
//! Without it a test prints a notice and passes, unless `RODLOG_INTEROP_REQUIRED=1` (CI),
//! where it fails.

use std::path::PathBuf;

/// The venv's `bin/<tool>`, or `None` (with a notice naming `check`) when it is absent.
///
/// # Panics
/// When `RODLOG_INTEROP_REQUIRED=1` and the tool is missing.
pub fn venv_tool(tool: &str, check: &str) -> Option<PathBuf> {
    let dir = std::env::var_os("RODLOG_REF_VENV").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(".venv-ref"),
        PathBuf::from,
    );
    let exe = dir.join("bin").join(tool);
    if exe.is_file() {
        return Some(exe);
    }
    let required = std::env::var("RODLOG_INTEROP_REQUIRED").is_ok_and(|v| v == "1");
    assert!(
        !required,
        "RODLOG_INTEROP_REQUIRED=1 but no {} (run scripts/venv.sh)",
        exe.display()
    );
    eprintln!(
        "NOTICE: {check} skipped: no {} (run scripts/venv.sh)",
        exe.display()
    );
    None
}

/// The venv's directory when its `bin/python` exists (see [`venv_tool`]).
#[allow(dead_code)] // not every test binary that includes this module needs it
pub fn venv_dir(check: &str) -> Option<PathBuf> {
    venv_tool("python", check).and_then(|py| Some(py.parent()?.parent()?.to_path_buf()))
}
