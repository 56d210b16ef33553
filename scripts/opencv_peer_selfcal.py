#!/usr/bin/env python3
"""OpenCV peer of `rodlog calib self`: hand-eye self-calibration from natural
features with stock OpenCV, on a rodlog recording (ROS 2 MCAP, decoded by mcap_ros2).

Usage: opencv_peer_selfcal.py REC.mcap|VIEWS_DIR [--mode auto|rgbd|mono] [--features sift|orb]
                              [--nfeatures N] [--threads N]

VIEWS_DIR instead of a recording: a folder with views.json, {"k": [9, row-major],
"dist": [k1, k2, p1, p2, k3], "views": [{"gray": PNG file, "depth": raw little-endian
float32 metres file or null, "width", "height", "base_from_tool0": [16, row-major]}]}
(`rodlog experiment noise` writes its noisy views so, to run this peer on the same pixels).

Reads only what the robot has: /camera/color/image_raw, /camera/depth/image_raw,
/camera/color/camera_info, /tf and /tf_static (hand pose base_link -> tool0, interpolated at
each image stamp). Never reads /sim/... (ground truth: see selfcal_truth_errors.py).

RGB-D: SIFT (or ORB) + brute-force kNN + Lowe ratio 0.8 per view pair (i < j); the matched
keypoints of view i are back-projected with its registered depth (undistorted rays), and
cv2.solvePnPRansac + solvePnPRefineLM in view j give cam_j_from_cam_i. A maximum spanning
tree over the pair graph (weight = PnP inliers) chains the pairs into one world frame (view
of the tree root); the absolute poses go to cv2.calibrateHandEye with its five methods.

Mono: the same matches, cv2.findEssentialMat (RANSAC, undistorted points) + recoverPose per
pair -> rotation and unit translation. R_X by cv2.calibrateHandEye (its rotation step does
not use the translations; they are chained unit translations), then t_X and one scale per
pair by linear least squares on (R_B - I) t_X - s_ij R_X u_ij = -t_B (numpy).

Prints one JSON object: {"mode", "features", "views", "pairs_used", "time_s",
"methods": {name: {"translation_m": [x,y,z], "rotation": [[3x3]], "quaternion_xyzw": [...]}}}
with every result as tool0_from_camera (= OpenCV's cam2gripper).
"""

import argparse
import json
import os
import sys
import time

import cv2
import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

METHODS = {
    "tsai": cv2.CALIB_HAND_EYE_TSAI,
    "park": cv2.CALIB_HAND_EYE_PARK,
    "horaud": cv2.CALIB_HAND_EYE_HORAUD,
    "andreff": cv2.CALIB_HAND_EYE_ANDREFF,
    "daniilidis": cv2.CALIB_HAND_EYE_DANIILIDIS,
}
BASE, TOOL = "base_link", "tool0"
COLOR, DEPTH, INFO = "/camera/color/image_raw", "/camera/depth/image_raw", "/camera/color/camera_info"
RATIO = 0.8
MIN_MATCHES = 30


def quat_to_rot(x, y, z, w):
    n = np.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def rot_to_quat(r):
    """(x, y, z, w) of a rotation matrix (Shepperd)."""
    t = np.trace(r)
    if t > 0:
        s = np.sqrt(t + 1.0) * 2
        w, x, y, z = 0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = np.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2]) * 2
        w, x, y, z = (r[2, 1] - r[1, 2]) / s, 0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s
    elif r[1, 1] > r[2, 2]:
        s = np.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2]) * 2
        w, x, y, z = (r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s
    else:
        s = np.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1]) * 2
        w, x, y, z = (r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s
    q = np.array([x, y, z, w])
    return q if w >= 0 else -q


def slerp(q0, q1, a):
    d = float(np.dot(q0, q1))
    if d < 0:
        q1, d = -q1, -d
    if d > 0.9995:
        q = q0 + a * (q1 - q0)
        return q / np.linalg.norm(q)
    th = np.arccos(d)
    return (np.sin((1 - a) * th) * q0 + np.sin(a * th) * q1) / np.sin(th)


def hom(r, t):
    m = np.eye(4)
    m[:3, :3] = r
    m[:3, 3] = t
    return m


class Tf:
    """Minimal TF tree: static edges and time-sorted dynamic samples, linear/slerp."""

    def __init__(self):
        self.static = {}
        self.dynamic = {}

    def add(self, ts, is_static):
        child = ts.child_frame_id
        t = ts.transform
        q = np.array([t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w])
        v = np.array([t.translation.x, t.translation.y, t.translation.z])
        if is_static:
            self.static[child] = (ts.header.frame_id, q, v)
        else:
            stamp = ts.header.stamp.sec * 1_000_000_000 + ts.header.stamp.nanosec
            self.dynamic.setdefault(child, (ts.header.frame_id, []))[1].append((stamp, q, v))

    def finish(self):
        for _, (_, s) in self.dynamic.items():
            s.sort(key=lambda e: e[0])

    def edge(self, child, stamp):
        if child in self.static:
            p, q, v = self.static[child]
            return p, hom(quat_to_rot(*q), v)
        if child not in self.dynamic:
            raise KeyError(f"no TF edge to {child}")
        p, s = self.dynamic[child]
        stamps = [e[0] for e in s]
        k = int(np.searchsorted(stamps, stamp))
        if k < len(s) and s[k][0] == stamp:
            return p, hom(quat_to_rot(*s[k][1]), s[k][2])
        if k == 0 or k == len(s):
            raise KeyError(f"stamp {stamp} outside the TF range of {child}")
        (t0, q0, v0), (t1, q1, v1) = s[k - 1], s[k]
        a = (stamp - t0) / (t1 - t0)
        return p, hom(quat_to_rot(*slerp(q0, q1, a)), v0 + a * (v1 - v0))

    def lookup(self, parent, child, stamp):
        m = np.eye(4)
        frame = child
        while frame != parent:
            p, e = self.edge(frame, stamp)
            m = e @ m
            frame = p
        return m


def read(path, mode):
    tf = Tf()
    info, colour, depth = None, [], {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        topics = ["/tf", "/tf_static", INFO, COLOR] + ([] if mode == "mono" else [DEPTH])
        for _, channel, _, msg in reader.iter_decoded_messages(topics=topics):
            if channel.topic in ("/tf", "/tf_static"):
                for ts in msg.transforms:
                    tf.add(ts, channel.topic == "/tf_static")
            elif channel.topic == INFO:
                info = msg if info is None else info
            else:
                stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
                h, w = msg.height, msg.width
                buf = bytes(msg.data)
                if channel.topic == COLOR:
                    enc = msg.encoding
                    ch = 1 if enc == "mono8" else 3
                    a = np.frombuffer(buf, np.uint8).reshape(h, msg.step)[:, : w * ch].reshape(h, w, ch)
                    if enc == "rgb8":
                        g = cv2.cvtColor(a, cv2.COLOR_RGB2GRAY)
                    elif enc == "bgr8":
                        g = cv2.cvtColor(a, cv2.COLOR_BGR2GRAY)
                    else:
                        g = a[:, :, 0].copy()
                    colour.append((stamp, g))
                else:
                    if msg.encoding == "32FC1":
                        d = np.frombuffer(buf, "<f4").reshape(h, msg.step // 4)[:, :w].astype(np.float64)
                    else:
                        d = np.frombuffer(buf, "<u2").reshape(h, msg.step // 2)[:, :w].astype(np.float64) * 1e-3
                    depth[stamp] = d
    tf.finish()
    if info is None or not colour:
        raise SystemExit("no camera_info or no colour images")
    k = np.array(info.k, dtype=np.float64).reshape(3, 3)
    dist = np.array(list(info.d) + [0.0] * (5 - len(info.d)), dtype=np.float64)[:5]
    views = []
    for stamp, g in colour:
        b = tf.lookup(BASE, TOOL, stamp)
        views.append({"stamp": stamp, "gray": g, "depth": depth.get(stamp), "base_from_tool0": b})
    return views, k, dist


def read_views_dir(path):
    """The views of a VIEWS_DIR (module docs)."""
    with open(os.path.join(path, "views.json")) as f:
        spec = json.load(f)
    k = np.array(spec["k"], dtype=np.float64).reshape(3, 3)
    dist = np.array(list(spec["dist"]) + [0.0] * 5, dtype=np.float64)[:5]
    views = []
    for i, v in enumerate(spec["views"]):
        g = cv2.imread(os.path.join(path, v["gray"]), cv2.IMREAD_GRAYSCALE)
        if g is None:
            raise SystemExit(f"view {i}: cannot read {v['gray']}")
        d = None
        if v.get("depth"):
            d = np.fromfile(os.path.join(path, v["depth"]), "<f4").astype(np.float64)
            d = d.reshape(v["height"], v["width"])
        b = np.array(v["base_from_tool0"], dtype=np.float64).reshape(4, 4)
        views.append({"stamp": i, "gray": g, "depth": d, "base_from_tool0": b})
    return views, k, dist


def features(views, kind, n):
    det = cv2.SIFT_create(nfeatures=n) if kind == "sift" else cv2.ORB_create(nfeatures=n)
    out = []
    for v in views:
        kp, des = det.detectAndCompute(v["gray"], None)
        out.append((np.array([p.pt for p in kp], dtype=np.float64).reshape(-1, 2), des))
    norm = cv2.NORM_L2 if kind == "sift" else cv2.NORM_HAMMING
    return out, cv2.BFMatcher(norm)


def match(matcher, fa, fb):
    if fa[1] is None or fb[1] is None or len(fa[0]) < 2 or len(fb[0]) < 2:
        return np.zeros((0, 2)), np.zeros((0, 2))
    knn = matcher.knnMatch(fa[1], fb[1], k=2)
    good = [m[0] for m in knn if len(m) == 2 and m[0].distance < RATIO * m[1].distance]
    pa = np.array([fa[0][m.queryIdx] for m in good]).reshape(-1, 2)
    pb = np.array([fb[0][m.trainIdx] for m in good]).reshape(-1, 2)
    return pa, pb


def undistort(p, k, dist):
    return cv2.undistortPoints(p.reshape(-1, 1, 2), k, dist).reshape(-1, 2)


def pnp_pair(vi, pa, pb, k, dist):
    """cam_j_from_cam_i (4x4) and the inlier count, or None."""
    d = vi["depth"]
    h, w = d.shape
    u = np.clip(np.round(pa[:, 0]).astype(int), 0, w - 1)
    v = np.clip(np.round(pa[:, 1]).astype(int), 0, h - 1)
    z = d[v, u]
    ok = np.isfinite(z) & (z > 0)
    if ok.sum() < MIN_MATCHES:
        return None
    n = undistort(pa[ok], k, dist)
    obj = np.column_stack([n * z[ok, None], z[ok]])
    img = pb[ok].reshape(-1, 1, 2)
    found, rvec, tvec, inl = cv2.solvePnPRansac(
        obj, img, k, dist, iterationsCount=1000, reprojectionError=2.0, confidence=0.999,
        flags=cv2.SOLVEPNP_EPNP)
    if not found or inl is None or len(inl) < MIN_MATCHES:
        return None
    inl = inl.ravel()
    rvec, tvec = cv2.solvePnPRefineLM(obj[inl], img[inl], k, dist, rvec, tvec)
    r, _ = cv2.Rodrigues(rvec)
    return hom(r, tvec.ravel()), len(inl)


def essential_pair(pa, pb, k, dist):
    """cam_j_from_cam_i with unit translation, and the inlier count, or None."""
    na, nb = undistort(pa, k, dist), undistort(pb, k, dist)
    thr = 1.0 / k[0, 0]
    e, mask = cv2.findEssentialMat(na, nb, np.eye(3), method=cv2.RANSAC, prob=0.999, threshold=thr)
    if e is None or e.shape != (3, 3):
        return None
    n, r, t, mask2 = cv2.recoverPose(e, na, nb, np.eye(3), mask=mask)
    if n < MIN_MATCHES:
        return None
    return hom(r, t.ravel() / np.linalg.norm(t)), int(n)


def spanning_tree(n, edges):
    """Maximum spanning tree (Prim) from the best-connected view: {view: cam_root_from_cam_view}."""
    adj = {}
    for (i, j), (j_from_i, w) in edges.items():
        adj.setdefault(i, []).append((w, j, np.linalg.inv(j_from_i)))  # i_from_j
        adj.setdefault(j, []).append((w, i, j_from_i))
    if not adj:
        return {}
    root = max(adj, key=lambda a: sum(e[0] for e in adj[a]))
    poses = {root: np.eye(4)}
    while True:
        best = None
        for a in poses:
            for w, b, a_from_b in adj.get(a, []):
                if b not in poses and (best is None or w > best[0]):
                    best = (w, a, b, a_from_b)
        if best is None:
            return poses
        _, a, b, a_from_b = best
        poses[b] = poses[a] @ a_from_b


def as_result(r, t):
    return {"translation_m": [float(x) for x in t], "rotation": r.tolist(),
            "quaternion_xyzw": [float(x) for x in rot_to_quat(r)]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rec")
    ap.add_argument("--mode", default="auto", choices=["auto", "rgbd", "mono"])
    ap.add_argument("--features", default="sift", choices=["sift", "orb"])
    ap.add_argument("--nfeatures", type=int, default=4000)
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    cv2.setNumThreads(a.threads)
    cv2.setRNGSeed(1)
    t0 = time.perf_counter()
    views, k, dist = read_views_dir(a.rec) if os.path.isdir(a.rec) else read(a.rec, a.mode)
    mode = a.mode
    if mode == "auto":
        mode = "rgbd" if all(v["depth"] is not None for v in views) else "mono"
    if mode == "rgbd" and any(v["depth"] is None for v in views):
        raise SystemExit("rgbd mode: a view has no depth at its stamp")
    feats, matcher = features(views, a.features, a.nfeatures)
    edges = {}
    for i in range(len(views)):
        for j in range(i + 1, len(views)):
            pa, pb = match(matcher, feats[i], feats[j])
            if len(pa) < MIN_MATCHES:
                continue
            if mode == "mono" and not mono_baseline_ok(views[i], views[j]):
                continue
            res = pnp_pair(views[i], pa, pb, k, dist) if mode == "rgbd" else essential_pair(pa, pb, k, dist)
            if res is not None:
                edges[(i, j)] = res
    poses = spanning_tree(len(views), edges)  # view -> cam_root_from_cam_view
    used = sorted(poses)
    if len(used) < 3:
        raise SystemExit(f"only {len(used)} views connected by pair motions")
    r_g2b = [views[v]["base_from_tool0"][:3, :3] for v in used]
    t_g2b = [views[v]["base_from_tool0"][:3, 3] for v in used]
    target2cam = [np.linalg.inv(poses[v]) for v in used]  # cam_v_from_root
    r_t2c = [m[:3, :3] for m in target2cam]
    t_t2c = [m[:3, 3] for m in target2cam]
    methods = {}
    for name, flag in METHODS.items():
        r, t = cv2.calibrateHandEye(r_g2b, t_g2b, r_t2c, t_t2c, method=flag)
        r = np.asarray(r, dtype=np.float64)
        t = np.asarray(t, dtype=np.float64).ravel()
        if mode == "mono":
            t = mono_translation(views, edges, r)
        methods[name] = as_result(r, t)
    print(json.dumps({
        "mode": mode, "features": a.features, "views": len(used), "pairs_used": len(edges),
        "time_s": time.perf_counter() - t0, "methods": methods,
    }))


def mono_baseline_ok(vi, vj):
    """An essential matrix needs a baseline: hand translation >= 3 cm and rotation >= 3 deg."""
    bij = np.linalg.inv(vi["base_from_tool0"]) @ vj["base_from_tool0"]
    angle = np.degrees(np.arccos(np.clip((np.trace(bij[:3, :3]) - 1) / 2, -1, 1)))
    return np.linalg.norm(bij[:3, 3]) >= 0.03 and angle >= 3.0


def mono_translation(views, edges, r_x):
    """t_X and per-pair scales by least squares on (R_B - I) t_X - s_ij R_X u_ij = -t_B,
    with B_ij = tool_i_from_tool_j and A_ij = cam_i_from_cam_j (u_ij its unit translation);
    pairs with a non-positive scale or a residual > 3x the median are dropped (3 rounds)."""
    pairs = sorted(edges)
    rows = []
    for (i, j) in pairs:
        j_from_i, _ = edges[(i, j)]
        i_from_j = np.linalg.inv(j_from_i)
        bij = np.linalg.inv(views[i]["base_from_tool0"]) @ views[j]["base_from_tool0"]
        rows.append((bij[:3, :3] - np.eye(3), -(r_x @ i_from_j[:3, 3]), -bij[:3, 3]))
    keep = list(range(len(rows)))
    t_x = np.zeros(3)
    for _ in range(3):
        n = len(keep)
        a = np.zeros((3 * n, 3 + n))
        b = np.zeros(3 * n)
        for k, idx in enumerate(keep):
            m, u, rhs = rows[idx]
            a[3 * k:3 * k + 3, :3] = m
            a[3 * k:3 * k + 3, 3 + k] = u
            b[3 * k:3 * k + 3] = rhs
        sol, *_ = np.linalg.lstsq(a, b, rcond=None)
        t_x = sol[:3]
        res = np.array([np.linalg.norm(a[3 * k:3 * k + 3] @ sol - b[3 * k:3 * k + 3]) for k in range(n)])
        med = np.median(res)
        new = [idx for k, idx in enumerate(keep) if sol[3 + k] > 0 and res[k] <= 3 * med + 1e-12]
        if len(new) == len(keep) or len(new) < 3:
            break
        keep = new
    return t_x


if __name__ == "__main__":
    sys.exit(main())
