#!/usr/bin/env python3
"""Seed corpora for the fuzz harnesses, small valid files of each kind (libFuzzer mutates from them):
    fuzz/make_seeds.py OUT_DIR
The cloud and mesh harnesses read their first byte as the format (cloud: even PCD, odd PLY; mesh: 0 STL, 1 PLY,
2 OBJ), so each seed starts with it. The shipped part meshes and specs are added as they are."""
import json
import os
import shutil
import struct
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
out = sys.argv[1]
for d in ("cloud", "mesh", "part_spec", "scan_log"):
    os.makedirs(os.path.join(out, d), exist_ok=True)


def put(kind, name, data):
    with open(os.path.join(out, kind, name), "wb") as f:
        f.write(data)


pts = [(0.3 + 0.01 * i, 0.1 * (i % 3), 0.002 * i) for i in range(30)]
head = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH %d\nHEIGHT 1\nPOINTS %d\nDATA %s\n"
put("cloud", "ascii.pcd", b"\0" + (head % (30, 30, "ascii") + "".join("%g %g %g\n" % p for p in pts)).encode())
put("cloud", "binary.pcd", b"\0" + (head % (30, 30, "binary")).encode() + b"".join(struct.pack("<3f", *p) for p in pts))
vp = ("VERSION 0.7\nFIELDS x y z vp_x vp_y vp_z\nSIZE 4 4 4 4 4 4\nTYPE F F F F F F\nCOUNT 1 1 1 1 1 1\nWIDTH 30\n"
      "HEIGHT 1\nPOINTS 30\nDATA ascii\n") + "".join("%g %g %g 0 0 0.5\n" % p for p in pts)
put("cloud", "viewpoints.pcd", b"\0" + vp.encode())
ply = "ply\nformat %s 1.0\nelement vertex 30\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
put("cloud", "ascii.ply", b"\1" + (ply % "ascii" + "".join("%g %g %g\n" % p for p in pts)).encode())
put("cloud", "binary.ply", b"\1" + (ply % "binary_little_endian").encode() + b"".join(struct.pack("<3f", *p) for p in pts))

parts = os.path.join(ROOT, "scenes", "parts")
for name in sorted(os.listdir(parts)):
    path = os.path.join(parts, name)
    if name.endswith(".stl") and os.path.getsize(path) < 20000:
        put("mesh", name, b"\0" + open(path, "rb").read())
    if name.endswith(".yaml"):
        spec = open(path).read().replace("model: " + name[:-5] + ".stl", "model: part.stl")
        put("part_spec", name, spec.encode())
box = ("ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\nelement face 6\n"
       "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
       "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n")
put("mesh", "box.ply", b"\1" + box.encode())
put("mesh", "box.obj", b"\2" + b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 1\nf 1 2 3\nf 1 3 4\n")

header = {"source": "seed", "robot": "aubo_i5", "lidar_frame": "lidar", "lidar_model": "rplidar_a2",
          "joint_names": ["j%d" % i for i in range(1, 7)], "num_turns": 2, "num_samples": 8, "num_joint_states": 3,
          "byte_order": "little"}
body = struct.pack("<dII", 0.0, 0, 4) + struct.pack("<dII", 0.1, 4, 4)
body += b"".join(struct.pack("<dffB", 0.025 * i, 0.5 * i, 1.0 + 0.1 * i, 40) for i in range(8))
body += b"".join(struct.pack("<7d", 0.1 * i, *[0.01 * i] * 6) for i in range(3))
put("scan_log", "small.scanlog", b"WELDTWIN-SCANLOG 1\n" + json.dumps(header).encode() + b"\n" + body)
