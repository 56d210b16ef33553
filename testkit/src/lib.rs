//! Test support: the one place that decides whether a test may skip.
//!
//! Some tests need something outside the repository: the reference venv of
//! `scripts/venv.sh` (OpenCV, the Rerun viewer, the ROS 2 decoders, Cyclone DDS) or the public
//! data under `../shared/data`. On a developer's machine without them such a test prints a
//! `NOTICE: ... skipped` line and passes. With `RODLOG_NO_SKIP=1` (what `.ci/run` sets) a
//! skip is a failure instead, so CI never passes a test it did not run.
//!
//! - [`ref_venv`], [`venv_tool`], [`venv_python_with`]: the venv (`RODLOG_REF_VENV`, default `<repo>/.venv-ref`).
//! - [`shared_data`]: a file or folder of the shared data (`RODLOG_SHARED_DATA`, default
//!   `<repo>/../shared/data`).
//! - [`skip`]: the decision itself, for any other missing requirement.

use std::path::{Path, PathBuf};

/// The environment variable that turns every skip into a failure.
pub const NO_SKIP_ENV: &str = "RODLOG_NO_SKIP";

/// The repository root (this crate's parent folder).
#[must_use]
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// True when skips are failures (`RODLOG_NO_SKIP=1`).
#[must_use]
pub fn skips_forbidden() -> bool {
    std::env::var(NO_SKIP_ENV).is_ok_and(|v| v == "1")
}

/// Skips `test` because of `why`: prints a notice, or panics when skips are forbidden.
///
/// # Panics
/// With `RODLOG_NO_SKIP=1`.
pub fn skip(test: &str, why: &str) {
    assert!(
        !skips_forbidden(),
        "{test} cannot run: {why} ({NO_SKIP_ENV}=1 forbids skipping; .ci/run installs what tests need)"
    );
    eprintln!("NOTICE: {test} skipped: {why}");
}

/// The reference venv's folder (with `bin/python`), or `None` after [`skip`].
///
/// # Panics
/// With `RODLOG_NO_SKIP=1` when the venv is missing.
#[must_use]
pub fn ref_venv(test: &str) -> Option<PathBuf> {
    let dir = std::env::var_os("RODLOG_REF_VENV")
        .map_or_else(|| repo_root().join(".venv-ref"), PathBuf::from);
    if dir.join("bin").join("python").is_file() {
        return Some(dir);
    }
    skip(
        test,
        &format!(
            "no reference venv at {} (run scripts/venv.sh)",
            dir.display()
        ),
    );
    None
}

/// The reference venv's `bin/TOOL`, or `None` after [`skip`].
///
/// # Panics
/// With `RODLOG_NO_SKIP=1` when the tool is missing.
#[must_use]
pub fn venv_tool(tool: &str, test: &str) -> Option<PathBuf> {
    let venv = ref_venv(test)?;
    let exe = venv.join("bin").join(tool);
    if exe.is_file() {
        return Some(exe);
    }
    skip(test, &format!("no {} (run scripts/venv.sh)", exe.display()));
    None
}

/// The reference venv's `bin/python` when it can import `module`, or `None` after [`skip`].
///
/// # Panics
/// With `RODLOG_NO_SKIP=1` when the venv or the module is missing.
#[must_use]
pub fn venv_python_with(module: &str, test: &str) -> Option<PathBuf> {
    let python = venv_tool("python", test)?;
    let importable = std::process::Command::new(&python)
        .args(["-c", &format!("import {module}")])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if importable {
        return Some(python);
    }
    skip(
        test,
        &format!(
            "{} cannot import {module} (run scripts/venv.sh)",
            python.display()
        ),
    );
    None
}

/// The shared data folder (`RODLOG_SHARED_DATA`, default `<repo>/../shared/data`).
#[must_use]
pub fn shared_data_dir() -> PathBuf {
    std::env::var_os("RODLOG_SHARED_DATA")
        .map_or_else(|| repo_root().join("../shared/data"), PathBuf::from)
}

/// `relative` under the shared data folder when it exists, or `None` after [`skip`].
///
/// # Panics
/// With `RODLOG_NO_SKIP=1` when it is missing.
#[must_use]
pub fn shared_data(relative: &str, test: &str) -> Option<PathBuf> {
    let path = shared_data_dir().join(relative);
    if path.exists() {
        return Some(path);
    }
    skip(
        test,
        &format!(
            "{} is absent (set RODLOG_SHARED_DATA to the shared data folder)",
            path.display()
        ),
    );
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_repository_root_holds_the_workspace() {
        assert!(repo_root().join("Cargo.toml").is_file());
    }

    #[test]
    fn a_missing_requirement_fails_exactly_when_skips_are_forbidden() {
        let missing = std::panic::catch_unwind(|| shared_data("no/such/file", "this test"));
        assert_eq!(missing.is_err(), skips_forbidden());
    }
}
