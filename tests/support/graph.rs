//! Processes of the ROS 2 graph tests: `rodlog` on a domain (loopback only) and the Cyclone
//! DDS peer (`scripts/dds/cyclone_peer.py`), started, awaited, and killed if they overrun
//! (only the processes a test started).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

/// The repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `rodlog ARGS` on domain `domain`, loopback only, started in the background.
pub fn spawn_rodlog(domain: u16, args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .current_dir(repo())
        .args(args)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start rodlog")
}

/// Waits for `child` up to `within`; kills it (this test started it) when it overruns.
pub fn wait(child: Child, within: Duration, what: &str) -> Output {
    let end = Instant::now() + within;
    let mut child = child;
    loop {
        match child.try_wait().expect("poll child") {
            Some(_) => return child.wait_with_output().expect("collect output"),
            None if Instant::now() > end => {
                let _ = child.kill();
                let out = child.wait_with_output().expect("collect output");
                panic!(
                    "{what} did not finish within {within:?}; stderr: {}",
                    String::from_utf8_lossy(&out.stderr)
                );
            }
            None => std::thread::sleep(Duration::from_millis(50)),
        }
    }
}

/// Starts `cyclone_peer.py ARGS --out OUT` in the reference venv.
pub fn spawn_peer(python: &Path, out: &Path, args: &[&str]) -> Child {
    let _ = std::fs::remove_file(out);
    Command::new(python)
        .arg(repo().join("scripts/dds/cyclone_peer.py"))
        .args(args)
        .arg("--out")
        .arg(out)
        .env_remove("CYCLONEDDS_URI")
        .stdout(Stdio::null())
        .spawn()
        .expect("start cyclone_peer.py")
}

/// Waits for the peer and reads its JSON report.
pub fn peer_report(child: Child, out: &Path, within: Duration) -> Value {
    let status = wait(child, within, "cyclone_peer.py").status;
    assert!(status.success(), "cyclone_peer.py failed: {status}");
    let text = std::fs::read_to_string(out).expect("peer report");
    serde_json::from_str(&text).expect("peer JSON")
}

/// Bytes of a hex string.
pub fn hex(s: &str) -> Vec<u8> {
    (0..s.len() / 2)
        .map(|i| u8::from_str_radix(&s[2 * i..2 * i + 2], 16).expect("hex"))
        .collect()
}

/// Ends `child` (a process this test started) if it still runs, and collects its output.
pub fn stop(mut child: Child) -> Output {
    if child.try_wait().ok().flatten().is_none() {
        let _ = child.kill();
    }
    child.wait_with_output().expect("collect output")
}
