//! The subcommands, one module each.

pub mod calib;
pub mod check;
pub mod demo;
pub mod experiment;
pub mod import;
pub mod info;
pub mod log;
pub mod params;
pub mod record;
pub mod record_ros2;
pub mod recording_views;
pub mod replay;
pub mod sim;
pub mod survey;
pub mod view;

/// Prints `text` and a newline on stdout; a closed pipe (`rodlog ... | head`) is not an
/// error worth a panic, so it ends the output quietly.
///
/// # Errors
/// Other write errors.
pub fn print_stdout(text: &str) -> anyhow::Result<()> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|()| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}
