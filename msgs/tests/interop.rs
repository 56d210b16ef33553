//! Interop with two independent ROS 2 implementations in the reference venv: `rosbags`
//! (ROS 2 Jazzy typestore) and `mcap-ros2-support` (decoders built from our schema texts).
//!
//! For every sample: both decode our bytes and re-encode them to exactly our bytes; rosbags
//! accepts our `.msg` texts as identical to its Jazzy definitions; rosbags' big-endian
//! encoding decodes in Rust to the original message. Needs the venv (`RODLOG_REF_VENV`,
//! default `<repo>/.venv-ref`); skipped with a notice when it is absent (`testkit`: never in CI).

mod common;

use std::path::PathBuf;
use std::process::Command;

use msgs::Msg;

fn venv_python() -> Option<PathBuf> {
    let venv = testkit::ref_venv("rosbags/mcap-ros2 interop")?;
    // Canonical path: python finds its venv (pyvenv.cfg) from the path it is started by.
    let venv = std::fs::canonicalize(venv).ok()?;
    Some(venv.join("bin/python"))
}

#[test]
fn rosbags_and_mcap_ros2_agree_byte_for_byte() {
    let Some(python) = venv_python() else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("rodlog-msgs-interop-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let samples = common::samples();
    for (i, msg) in samples.iter().enumerate() {
        let stem = dir.join(format!("{i:02}"));
        let schema = Msg::schema_text(msg.type_name()).expect("schema");
        std::fs::write(stem.with_extension("type"), msg.type_name()).expect("write");
        std::fs::write(stem.with_extension("schema"), schema).expect("write");
        std::fs::write(stem.with_extension("cdr"), msg.encode().expect("encode")).expect("write");
    }
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/interop.py");
    let out = Command::new(&python)
        .arg(&script)
        .arg(&dir)
        .output()
        .expect("run python");
    assert!(
        out.status.success(),
        "interop.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut failures = Vec::new();
    for (i, msg) in samples.iter().enumerate() {
        let stem = dir.join(format!("{i:02}"));
        let name = msg.type_name();
        if let Ok(err) = std::fs::read_to_string(stem.with_extension("error")) {
            failures.push(format!("{name}: python error:\n{err}"));
            continue;
        }
        let ours = msg.encode().expect("encode");
        for ext in ["rosbags_le", "mcap_ros2"] {
            let theirs = std::fs::read(stem.with_extension(ext)).expect("read");
            if theirs != ours {
                failures.push(format!(
                    "{name}: {ext} bytes differ\n ours   {ours:02x?}\n theirs {theirs:02x?}"
                ));
            }
        }
        let be = std::fs::read(stem.with_extension("rosbags_be")).expect("read");
        assert_eq!(&be[..2], &[0, 0], "rosbags BE header");
        match Msg::decode(name, &be) {
            Ok(back) if &back == msg => {}
            Ok(back) => failures.push(format!("{name}: BE decodes to {back:?}")),
            Err(e) => failures.push(format!("{name}: BE decode error {e}")),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    println!(
        "{} types cross-checked with rosbags and mcap-ros2-support",
        samples.len()
    );
}
