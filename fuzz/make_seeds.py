#!/usr/bin/env python3
"""Seed corpora for the fuzz harnesses, small valid files of each kind (libFuzzer mutates from them):
    fuzz/make_seeds.py OUT_DIR [--seed-bags BIN] [--real DIR]
Harnesses that read their first byte as a format or a chunk size get it prefixed (cloud: even PCD, odd PLY;
mesh: 0 STL, 1 PLY, 2 OBJ; pose_plan, by the byte mod 3: pose, plan, LiDAR mount; ros_bag, by the byte mod 3: ROS 1, ROS 2 sqlite3,
ROS 2 MCAP; rplidar: even SCAN, odd EXPRESS, and the chunk size; aubo_messages: odd the state stream, even
the command replies, and the chunk size). The shipped
part meshes, part and cell specs are added as they are; --seed-bags runs fuzz/seed_bags (bags from weldtwin's
own writers); --real adds files made outside the project from DIR (its bags/ and rplidar/, as the real-data
README lays them out)."""
import argparse
import glob
import json
import os
import struct
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("--seed-bags")
ap.add_argument("--real")
args = ap.parse_args()
out = args.out
# part_file starts from nothing: its bodies are made by weldtwin itself (a kept prepared part), not here.
for d in ("cloud", "mesh", "part_spec", "cell_spec", "scan_log", "pose_plan", "ros_bag", "rplidar", "aubo_messages",
          "part_file"):
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
        spec = open(path).read().replace("model: " + name[:-5] + ".stl", "model: part.obj")
        if name != "tube_on_plate.yaml":  # the mesh beside it is tube_on_plate's: its height, or none
            spec = "\n".join(l for l in spec.split("\n") if not l.startswith("height_"))
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

cells = os.path.join(ROOT, "scenes", "cells")
for name in sorted(os.listdir(cells)):
    if name.endswith(".yaml"):
        put("cell_spec", name, open(os.path.join(cells, name), "rb").read())

pose = {"found": True, "T_base_part": [[0, -1, 0, 0.48], [1, 0, 0, 0.06], [0, 0, 1, 0.0], [0, 0, 0, 1]],
        "seam_error_bound_mm": 0.4}
put("pose_plan", "pose.json", b"\0" + json.dumps(pose).encode())
samples = []
for k in range(40):
    seam = 0 if 5 <= k < 20 else (1 if 22 <= k < 38 else -1)
    samples.append({"t": 0.005 * k, "q": [0.01 * k, 0, 1.57, 0, 1.57, 0], "tcp": [0.4, 0.05, 0.03, 1, 0, 0, 0],
                    "seam": seam, "arc": seam >= 0, "phase": "weld" if seam >= 0 else "approach"})
put("pose_plan", "plan.json", b"\1" + json.dumps({"part": "tube_on_plate", "ok": True, "samples": samples}).encode())
mount = {"lidar_link": "lidar", "correction": {"xyz_m": [0.002, -0.001, 0.0005], "rpy_deg": [0.3, -0.2, 0.1]}}
put("pose_plan", "mount.json", b"\2" + json.dumps(mount).encode())

if args.seed_bags:
    subprocess.run([args.seed_bags, os.path.join(out, "ros_bag")], check=True)


def node(angle_deg, dist_mm, quality, start):
    a = int(angle_deg * 64) << 1 | 1
    return bytes([(quality << 2) | (2 if not start else 1), a & 0xFF, a >> 8]) + struct.pack("<H", int(dist_mm * 4))


descriptor_scan = bytes([0xA5, 0x5A, 5, 0, 0, 0x40, 0x81])
nodes = b"".join(node(i * 2.0, 400 + i, 40, i == 0) for i in range(180))
put("rplidar", "scan.bin", bytes([16 << 1]) + descriptor_scan + nodes + nodes[:37])


def capsule(start_deg, new_turn):
    a = int(start_deg * 64)
    body = bytearray([0, 0, a & 0xFF, (a >> 8) | (0x80 if new_turn else 0)])
    for c in range(16):
        body += struct.pack("<HHB", (500 + c) << 2, (510 + c) << 2, 0)
    chk = 0
    for b in body[2:]:
        chk ^= b
    body[0] = 0xA0 | (chk & 0x0F)
    body[1] = 0x50 | (chk >> 4)
    return bytes(body)


put("rplidar", "express.bin", bytes([1 | (31 << 1)]) + b"".join(capsule(i * 11.25, i == 0) for i in range(40)))



def msgpack(v):
    """The MessagePack encoding of v (None, bool, int, float, str, list, dict): the RTDE payloads' form."""
    if v is None:
        return b"\xc0"
    if v is True or v is False:
        return b"\xc3" if v else b"\xc2"
    if isinstance(v, int):
        return struct.pack("B", v) if 0 <= v < 128 else (struct.pack("b", v) if -32 <= v < 0 else b"\xd3" + struct.pack(">q", v))
    if isinstance(v, float):
        return b"\xcb" + struct.pack(">d", v)
    if isinstance(v, str):
        b = v.encode()
        return (struct.pack("B", 0xA0 | len(b)) if len(b) < 32 else b"\xd9" + struct.pack("B", len(b))) + b
    if isinstance(v, list):
        return struct.pack("B", 0x90 | len(v)) + b"".join(msgpack(x) for x in v) if len(v) < 16 else \
            b"\xdc" + struct.pack(">H", len(v)) + b"".join(msgpack(x) for x in v)
    return struct.pack("B", 0x80 | len(v)) + b"".join(msgpack(k) + msgpack(x) for k, x in v.items())


def sof(payload):
    return b"SOF\x01" + struct.pack(">H", len(payload)) + payload


# aubo_messages: the first byte's lowest bit picks the state stream (1) or the command replies (0), the rest
# the chunk size - 1.
state = [0, [0.0, 0.0, 1.57, 0.0, 1.57, 0.0], [0.0] * 6, "Running", "Normal"]
stream = sof(msgpack([100, 0])) + b"".join(sof(msgpack(state)) for _ in range(5))
put("aubo_messages", "state.bin", bytes([(31 << 1) | 1]) + stream)
replies = [{"jsonrpc": "2.0", "result": 0, "id": 1},
           {"jsonrpc": "2.0", "result": -5, "id": 1},
           {"jsonrpc": "2.0", "error": {"code": -32601, "message": "method not found"}, "id": 1},
           {"jsonrpc": "2.0", "result": [0.1, 0.2, 0.3, 0.4, 0.5, 0.6], "id": 1}]
put("aubo_messages", "replies.txt", bytes([3 << 1]) + "".join(json.dumps(r) for r in replies).encode())

if args.real:
    real = args.real
    for path in sorted(glob.glob(os.path.join(real, "bags", "*.bag"))):
        put("ros_bag", "real_" + os.path.basename(path), b"\0" + open(path, "rb").read())
    for path in sorted(glob.glob(os.path.join(real, "bags", "*", "*.db3"))):
        put("ros_bag", "real_" + os.path.basename(path), b"\1" + open(path, "rb").read())
    for path in sorted(glob.glob(os.path.join(real, "bags", "*", "*.mcap"))):
        put("ros_bag", "real_" + os.path.basename(path), b"\2" + open(path, "rb").read())
    for path in sorted(glob.glob(os.path.join(real, "rplidar", "scan_node_stream", "*.bin"))):
        put("rplidar", "real_" + os.path.basename(path), bytes([32 << 1]) + open(path, "rb").read()[:60000])
    hexfile = os.path.join(real, "rplidar", "a2_class_capture_hex.txt")
    if os.path.exists(hexfile):
        tokens = []
        for line in open(hexfile):
            tokens += [t for t in line.split("->")[0].split() if len(t) == 2]
        put("rplidar", "real_capture.bin", bytes([8 << 1]) + bytes.fromhex("".join(tokens)))
    for path in sorted(glob.glob(os.path.join(real, "aubo_arcs", "*.jsonl"))):
        data = open(path, "rb").read()
        for k in range(0, min(len(data), 40000), 4000):  # the harness reads up to 4 kB
            put("aubo_messages", "real_%d_%s" % (k, os.path.basename(path)), bytes([15 << 1]) + data[k:k + 4000])
