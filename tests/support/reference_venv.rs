//! The throw-away Python venv of `scripts/venv.sh` (OpenCV, rerun-sdk, the ROS 2 decoders,
//! Cyclone DDS) that the interop and peer tests run. Whether a test may skip without it is
//! `testkit`'s decision (never in CI).

use std::path::PathBuf;

/// The venv's `bin/<tool>`, or `None` after a skip notice naming `check`.
///
/// # Panics
/// When skips are forbidden (`RODLOG_NO_SKIP=1`) and the tool is missing.
#[allow(dead_code)] // not every test binary that includes this module needs it
pub fn venv_tool(tool: &str, check: &str) -> Option<PathBuf> {
    testkit::venv_tool(tool, check)
}

/// The venv's directory when its `bin/python` exists (see [`venv_tool`]).
#[allow(dead_code)] // not every test binary that includes this module needs it
pub fn venv_dir(check: &str) -> Option<PathBuf> {
    testkit::ref_venv(check)
}
