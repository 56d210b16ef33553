#!/usr/bin/env python3
"""OpenCV reference for rodlog's relative pose estimators (calib::relpose).

Usage: opencv_relpose.py SETS.json

SETS.json: {"sets": [{"x_a": [[x, y], ...], "x_b": [[x, y], ...],       # normalised, undistorted
                      "threshold": T,                                  # Sampson, normalised units
                      "p_in_a": [[x, y, z], ...], "p_in_b": [...]}]}   # optional, metres

For every set, prints (one JSON array on stdout, floats with repr, round-trip exact):

  {"ransac": {...}, "usac_accurate": {...}, "umeyama": {...}}

* "ransac": cv2.findEssentialMat(x_b, x_a, I, RANSAC, prob 0.999, threshold T) then
  cv2.recoverPose on its inliers. OpenCV's convention x2^T E x1 = 0 with points1 = x_b and
  points2 = x_a makes recoverPose's (R, t) the motion a_from_b (p_a = R p_b + t), |t| = 1.
* "usac_accurate": the same with cv2.USAC_ACCURATE (GC-RANSAC local optimisation).
* "umeyama": cv2.estimateAffine3D(p_in_b, p_in_a, force_rotation=True) (Umeyama, no RANSAC),
  only when 3D points are given (send inliers only).

Each entry: {"rotation": [[3x3 row-major]], "translation": [x, y, z], "inliers": [0/1...],
"time_ms": wall time of the OpenCV calls}. Needs opencv-contrib-python-headless (4.x) and
numpy (scripts/venv.sh).
"""

import json
import sys
import time

import cv2
import numpy as np


def essential(xa, xb, threshold, method):
    k = np.eye(3)
    t0 = time.perf_counter()
    e, mask = cv2.findEssentialMat(xb, xa, k, method=method, prob=0.999, threshold=threshold,
                                   maxIters=5000)
    if e is None or e.shape != (3, 3):
        return None
    mask_rp = mask.copy()
    _, r, t, mask_rp = cv2.recoverPose(e, xb, xa, k, mask=mask_rp)
    elapsed = (time.perf_counter() - t0) * 1e3
    return {
        "rotation": r.tolist(),
        "translation": t.ravel().tolist(),
        "inliers": [int(v) for v in mask_rp.ravel()],
        "time_ms": elapsed,
    }


def umeyama(pa, pb):
    t0 = time.perf_counter()
    m, scale = cv2.estimateAffine3D(pb, pa, force_rotation=True)
    elapsed = (time.perf_counter() - t0) * 1e3
    return {
        "rotation": m[:, :3].tolist(),
        "translation": m[:, 3].tolist(),
        "scale": float(scale),
        "inliers": [],
        "time_ms": elapsed,
    }


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    with open(sys.argv[1], encoding="utf-8") as f:
        sets = json.load(f)["sets"]
    out = []
    for s in sets:
        xa = np.asarray(s["x_a"], dtype=np.float64).reshape(-1, 1, 2)
        xb = np.asarray(s["x_b"], dtype=np.float64).reshape(-1, 1, 2)
        entry = {
            "ransac": essential(xa, xb, s["threshold"], cv2.RANSAC),
            "usac_accurate": essential(xa, xb, s["threshold"], cv2.USAC_ACCURATE),
        }
        if s.get("p_in_a"):
            pa = np.asarray(s["p_in_a"], dtype=np.float64)
            pb = np.asarray(s["p_in_b"], dtype=np.float64)
            entry["umeyama"] = umeyama(pa, pb)
        out.append(entry)
    json.dump(out, sys.stdout)
    print()


if __name__ == "__main__":
    main()
