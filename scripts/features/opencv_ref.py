#!/usr/bin/env python3
"""OpenCV reference for rodlog's feature front end (calib::features), used by
calib/tests/features_opencv.rs.

  opencv_ref.py gms IN.json          -> {"mask": [bool, ...]}
      IN.json: {"size_a": [w, h], "size_b": [w, h], "kps_a": [[x, y], ...],
                "kps_b": [[x, y], ...], "matches": [[ia, ib], ...],
                "with_rotation": bool, "with_scale": bool, "threshold_factor": 6.0}
      runs cv2.xfeatures2d.matchGMS on exactly these keypoints and matches.
  opencv_ref.py orb-gms A.png B.png [--features N]
      -> {"keypoints_a": n, "keypoints_b": n, "bf_matches": n,
          "matches": [[xa, ya, la, xb, yb, lb], ...]}   (GMS inliers; l = pyramid octave)
      ORB (N features, OpenCV defaults otherwise), BFMatcher(NORM_HAMMING) nearest
      neighbour, matchGMS(threshold 6, no rotation, no scale).

Everything runs with cv2.setNumThreads(1). Needs opencv-contrib-python-headless<5 (the
venv of scripts/venv.sh). Prints one JSON object on stdout.
"""
import json
import sys

import cv2


def gms(path):
    with open(path) as f:
        d = json.load(f)
    kpa = [cv2.KeyPoint(float(x), float(y), 31.0) for x, y in d["kps_a"]]
    kpb = [cv2.KeyPoint(float(x), float(y), 31.0) for x, y in d["kps_b"]]
    ms = [cv2.DMatch(int(a), int(b), 0.0) for a, b in d["matches"]]
    # matchGMS returns the inliers in input order; recover the mask by identity.
    good = cv2.xfeatures2d.matchGMS(tuple(d["size_a"]), tuple(d["size_b"]), kpa, kpb, ms,
                                    withRotation=d.get("with_rotation", False),
                                    withScale=d.get("with_scale", False),
                                    thresholdFactor=d.get("threshold_factor", 6.0))
    kept = {(m.queryIdx, m.trainIdx) for m in good}
    return {"mask": [(int(a), int(b)) in kept for a, b in d["matches"]]}


def orb_gms(a_path, b_path, n):
    a = cv2.imread(a_path, cv2.IMREAD_GRAYSCALE)
    b = cv2.imread(b_path, cv2.IMREAD_GRAYSCALE)
    orb = cv2.ORB_create(nfeatures=n)
    ka, da = orb.detectAndCompute(a, None)
    kb, db = orb.detectAndCompute(b, None)
    bf = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=False).match(da, db)
    good = cv2.xfeatures2d.matchGMS((a.shape[1], a.shape[0]), (b.shape[1], b.shape[0]), ka, kb,
                                    bf, withRotation=False, withScale=False, thresholdFactor=6.0)
    out = []
    for m in good:
        pa, pb = ka[m.queryIdx], kb[m.trainIdx]
        out.append([pa.pt[0], pa.pt[1], pa.octave, pb.pt[0], pb.pt[1], pb.octave])
    return {"keypoints_a": len(ka), "keypoints_b": len(kb), "bf_matches": len(bf),
            "matches": out}


def main():
    cv2.setNumThreads(1)
    args = sys.argv[1:]
    if len(args) >= 2 and args[0] == "gms":
        res = gms(args[1])
    elif len(args) >= 3 and args[0] == "orb-gms":
        n = int(args[args.index("--features") + 1]) if "--features" in args else 2000
        res = orb_gms(args[1], args[2], n)
    else:
        sys.exit(__doc__)
    print(json.dumps(res))


if __name__ == "__main__":
    main()
