//! The subcommands, one module each.

pub mod calib;
pub mod import;
pub mod info;
pub mod record;
pub mod replay;
