#!/usr/bin/env python3
"""Times OpenCV 4.x (one thread) on the frames the rodlog feature benches use, for the
ratios: ORB (2000 features), BFMatcher(NORM_HAMMING) 2000 x 2000, and
cv2.xfeatures2d.matchGMS.

Usage: bench_opencv.py [A.png B.png] [--runs N]
  Defaults: target/features-bench/{a,b}.png, written by `cargo bench -p calib --bench orb`
  (a 1280x1024 crop of shecar 00.jpg and a homography warp of it). Run it right after the
  criterion benches so both see the same machine load. Prints medians (and quartiles) in ms.
Needs the venv of scripts/venv.sh (opencv-contrib-python-headless<5).
"""
import os
import statistics
import sys
import time

import cv2


def timed(fn, runs):
    ts = []
    out = None
    for _ in range(runs):
        t0 = time.perf_counter()
        out = fn()
        ts.append((time.perf_counter() - t0) * 1e3)
    q = statistics.quantiles(ts, n=4)
    return out, (statistics.median(ts), q[0], q[2])


def main():
    args = [a for a in sys.argv[1:]]
    runs = 100
    if "--runs" in args:
        i = args.index("--runs")
        runs = int(args[i + 1])
        del args[i:i + 2]
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    a_path, b_path = (args + [None, None])[:2]
    a_path = a_path or os.path.join(root, "target", "features-bench", "a.png")
    b_path = b_path or os.path.join(root, "target", "features-bench", "b.png")
    cv2.setNumThreads(1)
    a = cv2.imread(a_path, cv2.IMREAD_GRAYSCALE)
    b = cv2.imread(b_path, cv2.IMREAD_GRAYSCALE)
    if a is None or b is None:
        sys.exit(f"cannot read {a_path} / {b_path}; run `cargo bench -p calib --bench orb` first")
    orb = cv2.ORB_create(nfeatures=2000)
    (ka, da), t_orb = timed(lambda: orb.detectAndCompute(a, None), runs)
    kb, db = orb.detectAndCompute(b, None)
    bf = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=False)
    matches, t_bf = timed(lambda: bf.match(da, db), runs)
    size_a, size_b = (a.shape[1], a.shape[0]), (b.shape[1], b.shape[0])
    good, t_gms = timed(lambda: cv2.xfeatures2d.matchGMS(size_a, size_b, ka, kb, matches,
                                                         withRotation=False, withScale=False,
                                                         thresholdFactor=6.0), runs)
    print(f"OpenCV {cv2.__version__}, 1 thread, {a.shape[1]}x{a.shape[0]}, {runs} runs")
    for name, (med, q1, q3), extra in [
        ("orb/detect_and_compute/2000", t_orb, f"{len(ka)} keypoints"),
        (f"bf_hamming/{len(da)}x{len(db)}", t_bf, f"{len(matches)} matches"),
        ("gms", t_gms, f"{len(good)} inliers of {len(matches)}"),
    ]:
        print(f"{name:32s} median {med:8.3f} ms  (q1 {q1:.3f}, q3 {q3:.3f})  {extra}")


if __name__ == "__main__":
    main()
