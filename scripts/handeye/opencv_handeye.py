#!/usr/bin/env python3
"""OpenCV reference for rodlog's hand-eye solvers.

Usage: opencv_handeye.py HAND.txt EYE.txt [HAND2.txt EYE2.txt ...]

Each HAND/EYE pair is a pair of TUM pose files (ARCHITECTURE.md section 5: `timestamp tx ty tz qx qy qz
qw`, `#` comments): hand = base_from_tool0 (OpenCV's gripper2base), eye = world_from_camera
(whose inverse is OpenCV's target2cam). Lines pair by equal timestamp, in the hand file's
order. For each pair of files, prints OpenCV's `calibrateHandEye` result for its five
methods as tool0_from_camera (= OpenCV's cam2gripper):

  [{"tsai": {"rotation": [[3x3 row-major]], "translation": [x, y, z]}, "park": ..., ...}, ...]

one JSON array with one object per file pair (floats printed with repr, round-trip exact).
Needs opencv-contrib-python-headless<5 (5.x has no calibrateHandEye) and numpy.
"""

import json
import sys

import cv2
import numpy as np

METHODS = {
    "tsai": cv2.CALIB_HAND_EYE_TSAI,
    "park": cv2.CALIB_HAND_EYE_PARK,
    "horaud": cv2.CALIB_HAND_EYE_HORAUD,
    "andreff": cv2.CALIB_HAND_EYE_ANDREFF,
    "daniilidis": cv2.CALIB_HAND_EYE_DANIILIDIS,
}


def read_tum(path):
    """{timestamp: (R 3x3, t 3)} in file order."""
    poses = {}
    order = []
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            v = [float(x) for x in line.split()]
            if len(v) != 8:
                raise SystemExit(f"{path}:{number}: expected 8 fields, found {len(v)}")
            stamp, tx, ty, tz, qx, qy, qz, qw = v
            n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
            qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
            rot = np.array(
                [
                    [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                    [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                    [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
                ]
            )
            poses[stamp] = (rot, np.array([tx, ty, tz]))
            order.append(stamp)
    return poses, order


def calibrate(hand_path, eye_path):
    hand, order = read_tum(hand_path)
    eye, _ = read_tum(eye_path)
    r_g2b, t_g2b, r_t2c, t_t2c = [], [], [], []
    for stamp in order:
        if stamp not in eye:
            raise SystemExit(f"timestamp {stamp} is in {hand_path} but not in {eye_path}")
        rh, th = hand[stamp]
        re, te = eye[stamp]
        r_g2b.append(rh)
        t_g2b.append(th.reshape(3, 1))
        # target2cam = cam_from_world = (world_from_cam)^-1
        r_t2c.append(re.T)
        t_t2c.append((-re.T @ te).reshape(3, 1))
    out = {}
    for name, method in METHODS.items():
        rot, t = cv2.calibrateHandEye(r_g2b, t_g2b, r_t2c, t_t2c, method=method)
        out[name] = {
            "rotation": [[float(x) for x in row] for row in rot],
            "translation": [float(x) for x in t.reshape(3)],
        }
    return out


def main(argv):
    if len(argv) < 2 or len(argv) % 2:
        raise SystemExit(__doc__)
    results = [calibrate(argv[i], argv[i + 1]) for i in range(0, len(argv), 2)]
    json.dump(results, sys.stdout, allow_nan=True)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main(sys.argv[1:])
