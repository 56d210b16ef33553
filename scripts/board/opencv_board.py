#!/usr/bin/env python3
"""OpenCV reference for rodlog's board front end (calib::board).

findChessboardCorners + cornerSubPix + solvePnP on the shecar images (or any folder of
images), with the Theia radial intrinsics mapped to plumb_bob (k1, k2, 0, 0, 0).
Writes one JSON object: per image the refined corners (OpenCV order), the pose
world_from_camera (board frame = world) as a row-major 4x4, and the reprojection RMS.

Usage: opencv_board.py DIR [--cols 6 --rows 8 --square 0.0283] [-o out.json]
"""
import argparse
import glob
import json
import os
import sys

import cv2
import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--cols", type=int, default=6)
    ap.add_argument("--rows", type=int, default=8)
    ap.add_argument("--square", type=float, default=0.0283)
    ap.add_argument("--win", type=int, default=11)
    ap.add_argument("-o", "--out", default="-")
    a = ap.parse_args()
    K = np.array([[2439.50225, 0, 1615.55613], [0, 2439.50225, 867.03099], [0, 0, 1]])
    dist = np.array([0.18436, -0.32515, 0, 0, 0])
    obj = np.zeros((a.rows * a.cols, 3))
    for r in range(a.rows):
        for c in range(a.cols):
            obj[r * a.cols + c] = (c * a.square, r * a.square, 0)
    out = {"images": []}
    for path in sorted(glob.glob(os.path.join(a.dir, "*.jpg"))):
        gray = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        ok, corners = cv2.findChessboardCorners(
            gray, (a.cols, a.rows),
            cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        rec = {"name": os.path.basename(path), "found": bool(ok)}
        if ok:
            crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-3)
            corners = cv2.cornerSubPix(gray, corners, (a.win, a.win), (-1, -1), crit)
            ok2, rvec, tvec = cv2.solvePnP(obj, corners, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
            proj, _ = cv2.projectPoints(obj, rvec, tvec, K, dist)
            err = proj.reshape(-1, 2) - corners.reshape(-1, 2)
            rms = float(np.sqrt((err ** 2).sum(axis=1).mean()))
            R, _ = cv2.Rodrigues(rvec)
            cam_from_world = np.eye(4)
            cam_from_world[:3, :3] = R
            cam_from_world[:3, 3] = tvec.ravel()
            world_from_cam = np.linalg.inv(cam_from_world)
            rec.update(corners=corners.reshape(-1, 2).tolist(), rms_px=rms,
                       world_from_camera=world_from_cam.tolist())
        out["images"].append(rec)
        print(path, ok, rec.get("rms_px"), file=sys.stderr)
    text = json.dumps(out)
    if a.out == "-":
        print(text)
    else:
        with open(a.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
