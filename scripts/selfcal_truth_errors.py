#!/usr/bin/env python3
"""Scores hand-eye results against the simulator's true mount.

Usage: selfcal_truth_errors.py REC.mcap NAME=RESULT.json [NAME=RESULT.json ...]

Reads the true tool0_from_camera from REC's /sim/camera_mount (the last message; calib-18 has
no bump). This is the only place the truth is read: the calibration pipelines never see it.
A RESULT.json is either `rodlog calib self --json` output (translation_m, quaternion_xyzw) or
opencv_peer_selfcal.py output ({"methods": {name: {...}}}: every method is scored, and
`NAME:best` is the method closest to the truth, an oracle choice in the peer's favour).
Prints one JSON line per result: {"name", "e_rot_deg" (rotation angle of R_true^T R_est),
"e_R" (spectral norm of R_err - I), "e_t_mm"}.
"""
import json
import sys

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def quat_to_rot(x, y, z, w):
    n = np.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def truth(path):
    last = None
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, _, _, msg in reader.iter_decoded_messages(topics=["/sim/camera_mount"]):
            last = msg
    if last is None:
        raise SystemExit(f"{path}: no /sim/camera_mount")
    t, q = last.transform.translation, last.transform.rotation
    return quat_to_rot(q.x, q.y, q.z, q.w), np.array([t.x, t.y, t.z])


def score(rt, tt, r, t):
    err = rt.T @ r
    angle = np.degrees(np.arccos(np.clip((np.trace(err) - 1) / 2, -1, 1)))
    return {"e_rot_deg": float(angle), "e_R": float(np.linalg.norm(err - np.eye(3), 2)),
            "e_t_mm": float(np.linalg.norm(t - tt) * 1e3)}


def main():
    rt, tt = truth(sys.argv[1])
    for arg in sys.argv[2:]:
        name, path = arg.split("=", 1)
        try:
            res = json.load(open(path))
        except (OSError, ValueError) as e:
            print(json.dumps({"name": name, "error": str(e)}))
            continue
        if "methods" in res:
            scored = {m: score(rt, tt, np.array(v["rotation"]), np.array(v["translation_m"]))
                      for m, v in res["methods"].items()}
            for m, s in scored.items():
                print(json.dumps({"name": f"{name}:{m}", **s}))
            best = min(scored, key=lambda m: scored[m]["e_rot_deg"] / 0.01 + scored[m]["e_t_mm"] / 0.1)
            print(json.dumps({"name": f"{name}:best", "method": best, **scored[best]}))
        else:
            r = quat_to_rot(*res["quaternion_xyzw"])
            print(json.dumps({"name": name, **score(rt, tt, r, np.array(res["translation_m"]))}))


if __name__ == "__main__":
    main()
