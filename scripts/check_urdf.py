#!/usr/bin/env python3
"""Reads a URDF the way ROS tools' Python side does (yourdfpy: urdfdom's rules, a single
root, every joint's links defined, the scene graph built) and prints what it found as JSON.

Usage: scripts/check_urdf.py ROBOT.urdf [JOINTS_JSON]

JOINTS_JSON maps joint names to positions (m or rad); the printed `base_from` poses are the
links' 4x4 transforms in the root link at that configuration (zero for joints not given).
Used by tests/cli_view.rs (the URDF of `robot::robot_urdf` stays valid for ROS tools).
Exit status 1 when yourdfpy's validation fails.
"""

import json
import sys

import yourdfpy


def main() -> int:
    path = sys.argv[1]
    positions = json.loads(sys.argv[2]) if len(sys.argv) > 2 else {}
    urdf = yourdfpy.URDF.load(path, build_scene_graph=True, load_meshes=False)
    valid = bool(urdf.validate())
    cfg = [float(positions.get(name, 0.0)) for name in urdf.actuated_joint_names]
    urdf.update_cfg(cfg)
    visuals = {}
    for name, link in urdf.link_map.items():
        shapes = []
        for v in link.visuals:
            g = v.geometry
            if g.box is not None:
                shapes.append(["box", [float(s) for s in g.box.size]])
            elif g.cylinder is not None:
                shapes.append(["cylinder", [float(g.cylinder.radius), float(g.cylinder.length)]])
            elif g.sphere is not None:
                shapes.append(["sphere", [float(g.sphere.radius)]])
            elif g.mesh is not None:
                shapes.append(["mesh", [g.mesh.filename]])
        visuals[name] = shapes
    out = {
        "valid": valid,
        "errors": [str(e) for e in urdf.errors],
        "name": urdf.robot.name,
        "root": urdf.base_link,
        "links": sorted(urdf.link_map),
        "joints": {
            n: {"type": j.type, "parent": j.parent, "child": j.child}
            for n, j in urdf.joint_map.items()
        },
        "actuated": list(urdf.actuated_joint_names),
        "visuals": visuals,
        "base_from": {
            n: urdf.get_transform(n, urdf.base_link).tolist() for n in urdf.link_map
        },
    }
    print(json.dumps(out))
    return 0 if valid else 1


if __name__ == "__main__":
    sys.exit(main())
