#!/usr/bin/env bash
# Interop checks of rodlog's MCAP with the Python ROS 2 / MCAP tools and Rerun
# (ARCHITECTURE.md section 3): mcap-ros2-support + rosbags decode a rodlog recording of every topic field
# by field; rodlog reads a file written by Python's mcap_ros2.writer; `rerun mcap convert`
# recognises images, depth, camera info and TF. Fails (never skips) without the venv.
# Usage: scripts/interop/run.sh        (venv: $RODLOG_REF_VENV or <repo>/.venv-ref)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
export RODLOG_REF_VENV=${RODLOG_REF_VENV:-$root/.venv-ref}
if [ ! -x "$RODLOG_REF_VENV/bin/python" ]; then
  echo "interop: no Python venv at $RODLOG_REF_VENV (create it with scripts/venv.sh)" >&2
  exit 1
fi
export RODLOG_NO_SKIP=1
cd "$root"
cargo test -p rodlog --test interop -- --nocapture
