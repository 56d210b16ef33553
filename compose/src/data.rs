//! Where the public datasets are: the shared data folder and the shecar sample in it.
//!
//! The data is not in the repository (shecar is GPL-3.0); the experiments and the tests find
//! it through these, so both look in the same place.

use std::path::{Path, PathBuf};

/// The shared data folder: `RODLOG_SHARED_DATA`, else `../shared/data` beside the source
/// tree.
#[must_use]
pub fn shared_data_dir() -> PathBuf {
    std::env::var_os("RODLOG_SHARED_DATA").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"),
        PathBuf::from,
    )
}

/// The shecar sample folder (the paper's "dataset 2"): `RODLOG_SHECAR`, else `shecar` in
/// [`shared_data_dir`].
#[must_use]
pub fn shecar_dir() -> PathBuf {
    std::env::var_os("RODLOG_SHECAR")
        .map_or_else(|| shared_data_dir().join("shecar"), PathBuf::from)
}
