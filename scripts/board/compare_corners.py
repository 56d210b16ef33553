#!/usr/bin/env python3
"""Compares rodlog's refined board corners with OpenCV's.

Usage: compare_corners.py OURS.json OPENCV.json
OURS.json: written by `RODLOG_BOARD_CORNERS_OUT=FILE cargo test -p calib --test board_shecar`;
OPENCV.json: written by opencv_board.py. Prints per-image median / max corner distance (px)
and whether the orderings agree (same corner order, no 180-degree flip).
"""
import json
import sys

import numpy as np


def main():
    ours = json.load(open(sys.argv[1]))["images"]
    cv = json.load(open(sys.argv[2]))["images"]
    meds = []
    for i, (a, b) in enumerate(zip(ours, cv)):
        if not b.get("found"):
            print(f"{i:02d}: OpenCV did not find the board")
            continue
        pa = np.array(a["corners"])
        pb = np.array(b["corners"])
        d = np.linalg.norm(pa - pb, axis=1)
        flipped = np.linalg.norm(pa[::-1] - pb, axis=1)
        order = "same order" if np.median(d) < np.median(flipped) else "FLIPPED"
        d = min(d, flipped, key=np.median)
        meds.append(np.median(d))
        print(f"{i:02d}: median {np.median(d):.3f} px, max {d.max():.3f} px, {order}, "
              f"rms ours {a['rms_px']:.3f} opencv {b['rms_px']:.3f}")
    print(f"all: median of medians {np.median(meds):.3f} px, max median {max(meds):.3f} px")


if __name__ == "__main__":
    main()
