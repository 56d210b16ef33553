#!/usr/bin/env python3
"""Check that Rerun recognises a rodlog recording: `rerun mcap convert` then `rerun rrd print -v`.

Usage: check_rerun.py RERUN_BIN REC.mcap [DEPTH_MESSAGES]

Expected archetypes (Rerun 0.36 ROS 2 decoders), with the rows summed over chunks:
  /camera/color/image_raw     Image:buffer          (rgb8)
  /camera/depth/image_raw     DepthImage:buffer     (32FC1 and 16UC1, DEPTH_MESSAGES rows, default 2)
  /camera/color/camera_info   Pinhole:image_from_camera
  /tf, /tf_static             Transform3D:translation
Exit 0 when all are present with the right row counts.
"""
import re
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path


def main():
    rerun, rec = sys.argv[1], sys.argv[2]
    depth_rows = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    with tempfile.TemporaryDirectory() as tmp:
        rrd = Path(tmp) / "rec.rrd"
        conv = subprocess.run([rerun, "mcap", "convert", rec, "-o", str(rrd)],
                              capture_output=True, text=True, timeout=300)
        if conv.returncode != 0:
            print(conv.stdout, conv.stderr)
            print(f"FAIL: rerun mcap convert exited {conv.returncode}")
            return 1
        out = subprocess.run([rerun, "rrd", "print", "-v", str(rrd)],
                             capture_output=True, text=True, timeout=300)
        if out.returncode != 0:
            print(out.stdout, out.stderr)
            print(f"FAIL: rerun rrd print exited {out.returncode}")
            return 1
    rows = Counter()
    line_re = re.compile(r"with (\d+) rows .* - (\S+) - data columns: \[(.*)\]")
    for line in out.stdout.splitlines():
        m = line_re.search(line)
        if not m:
            continue
        n, entity, columns = int(m.group(1)), m.group(2), m.group(3)
        for col in columns.split():
            rows[col] += n
    expected = {
        "/camera/color/image_raw@Image:buffer": 1,
        "/camera/depth/image_raw@DepthImage:buffer": depth_rows,
        "/camera/color/camera_info@Pinhole:image_from_camera": 1,
        "/tf@Transform3D:translation": 1,
        "/tf_static@Transform3D:translation": 1,
    }
    errors = []
    for col, n in expected.items():
        # Columns may carry a fully qualified archetype name (rerun.archetypes.Image:buffer).
        got = sum(v for k, v in rows.items() if k == col or re.sub(r"@rerun\.\w+\.", "@", k) == col)
        if got < n:
            errors.append(f"{col}: {got} rows, expected {n}")
    for e in errors:
        print("MISSING", e)
    if errors:
        print("columns seen:", ", ".join(sorted(rows)))
        print("FAIL")
        return 1
    print("OK: rerun recognised " + ", ".join(f"{c} x{n}" for c, n in expected.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
