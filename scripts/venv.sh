#!/usr/bin/env bash
# Creates the throw-away Python venv of pinned reference tools used by tests and benchmarks
# (ARCHITECTURE.md section 8): OpenCV (hand-eye, ORB, SIFT), the Rerun viewer/CLI, two
# independent ROS 2 MCAP decoders, Eclipse Cyclone DDS (the independent DDS peer of
# ros2/tests), Ray (the scale-out driver of scripts/ray/) and a URDF parser with urdfdom's
# rules (yourdfpy: the robot's URDF stays valid for ROS tools). Idempotent: re-running only
# installs what is missing.
# The viewer tests run the venv's viewer headless: it needs a Vulkan rasteriser
# (apt-get install -y mesa-vulkan-drivers; xvfb too for scripts/viewer_screenshots.py);
# .ci/run installs both.
# Usage: scripts/venv.sh [DIR]   (default .venv-ref at the repository root)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv=${1:-$root/.venv-ref}
python3 -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
  "opencv-contrib-python-headless>=4.10,<5" \
  "numpy<3" \
  "rerun-sdk==0.36.3" \
  "mcap==1.*" \
  "mcap-ros2-support==0.5.*" \
  "rosbags==0.10.*" \
  "cyclonedds==11.0.1" \
  "ray==2.60.0" \
  "yourdfpy==0.0.60"
echo "$venv"
