//! `rodlog import folder|shecar DIR -o REC.mcap`: datasets on disk -> a recording
//! (ARCHITECTURE.md section 5; see `crate::import`).

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};

use crate::import;

/// `rodlog import` subcommands.
#[derive(Debug, Subcommand)]
pub enum ImportCommand {
    /// A folder dataset: camera.yaml, images/, optional depth/, hand_poses.txt (TUM).
    Folder(ImportArgs),
    /// ZHI's shecar sample layout: NN.jpg, handposes.txt, intrinsic.txt (Theia).
    Shecar(ImportArgs),
}

/// Arguments shared by the importers.
#[derive(Debug, Args)]
pub struct ImportArgs {
    /// Dataset directory.
    pub dir: PathBuf,
    /// Output recording.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Resize images by this factor in (0, 1] (intrinsics follow).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
}

/// Runs an import.
pub fn run(command: &ImportCommand) -> Result<()> {
    let (dataset, args) = match command {
        ImportCommand::Folder(args) => (import::folder::read(&args.dir)?, args),
        ImportCommand::Shecar(args) => (import::shecar::read(&args.dir)?, args),
    };
    let summary = import::write_recording(&dataset, &args.out, args.scale)?;
    eprintln!(
        "imported {} views ({} with depth), {} messages -> {}",
        summary.views,
        summary.depth_views,
        summary.messages,
        args.out.display()
    );
    Ok(())
}
