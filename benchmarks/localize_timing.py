#!/usr/bin/env python3
"""Whole-process time of `weldtwin localize` (start-up, reading, localizing, writing) on the sample scans,
ours and the paper's method, as a user runs it. The samples are ASCII PCD; each is also converted to binary
PCD (same points) so that the reader's share shows. Prints the median of REPEATS runs per case.

    benchmarks/localize_timing.py [--weldtwin build/app/weldtwin] [--samples DIR] [--real DIR] [--repeats 5]
                                  [--baseline OTHER_WELDTWIN]

--baseline: another build of weldtwin (an earlier commit, say), run interleaved with this one on the same
cases (each repeat runs both, so that a slower moment of the machine falls on both): its median beside ours
and the ratio ours/baseline.

--samples DIR: folders with scan.pcd and part.stl; --real DIR: real scans (*.pcd) with the part's mesh (*.stl)
beside them.

Ours is timed three ways: "cold", the part prepared anew (--no-part-cache); "known", the part kept by runs on
the other scans of the same mesh (samples only: a new placement of a part the cell has localized before; each
timed run starts from a copy of that folder); "warm", the part kept by an earlier run on the same scan. The
baseline is run as it is (a build from before the kept parts: cold).
"""
import argparse
import hashlib
import shutil
import os
import statistics
import struct
import subprocess
import tempfile
import time


def to_binary_pcd(src, dst):
    points, data = [], False
    with open(src) as f:
        for line in f:
            if data:
                parts = line.split()
                if len(parts) >= 3:
                    points.append(tuple(float(v) for v in parts[:3]))
            elif line.startswith("DATA"):
                data = True
    with open(dst, "wb") as out:
        n = len(points)
        out.write(("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                   f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n").encode())
        for p in points:
            out.write(struct.pack("<3f", *p))
    return len(points)


def wall_time(cmd):
    t0 = time.perf_counter()
    rc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    return time.perf_counter() - t0, rc


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weldtwin", default="build/app/weldtwin")
    ap.add_argument("--samples", default="../shared/samples")
    ap.add_argument("--real", default="")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--baseline", default="")
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="weldtwin_timing_")
    rows = []
    cases = []  # (name, scan, mesh)
    for name in sorted(os.listdir(args.samples)):
        d = os.path.join(args.samples, name)
        if os.path.isdir(d):
            cases.append((name, os.path.join(d, "scan.pcd"), os.path.join(d, "part.stl")))
    if args.real:
        meshes = sorted(f for f in os.listdir(args.real) if f.endswith(".stl"))
        for f in sorted(os.listdir(args.real)):
            if f.endswith(".pcd") and meshes:
                cases.append(("real " + f[:-4], os.path.join(args.real, f), os.path.join(args.real, meshes[0])))
    digest = {m: hashlib.md5(open(m, "rb").read()).hexdigest() for _, _, m in cases}

    def known_folder(name, mesh, fmt):
        """A folder of kept parts written by the other samples of the same mesh (None: there are none)."""
        others = [(n, sc) for n, sc, m in cases if digest[m] == digest[mesh] and n != name and not n.startswith("real")]
        if not others:
            return None
        folder = os.path.join(tmp, f"known_{name}_{fmt}")
        for _, other_scan in others:
            wall_time([args.weldtwin, "localize", "-q", "--model", mesh, "--scan", other_scan, "--out",
                       os.path.join(tmp, "pose.json"), "--part-cache", folder])
        return folder

    for name, ascii_scan, mesh in cases:
        binary = os.path.join(tmp, name.replace(" ", "_") + ".pcd")
        n = to_binary_pcd(ascii_scan, binary)
        for fmt, scan in (("ascii", ascii_scan), ("binary", binary)):
            kept = os.path.join(tmp, "parts")
            scratch = os.path.join(tmp, "known_now")
            known = known_folder(name, mesh, fmt)
            for method in ("cold", "known", "warm", "paper"):
                if method == "known" and known is None:
                    continue
                def command(binary, mode=method):
                    cmd = [binary, "localize", "-q", "--model", mesh, "--scan", scan,
                           "--out", os.path.join(tmp, "pose.json"),
                           "--method", "paper" if mode == "paper" else "ours"]
                    if mode == "cold":
                        cmd.append("--no-part-cache")
                    elif mode == "warm":
                        cmd += ["--part-cache", kept]
                    elif mode == "known":
                        cmd += ["--part-cache", scratch]
                    return cmd
                if method == "warm":
                    wall_time(command(args.weldtwin))  # keeps the part and its lookups
                times, base_times = [], []
                for _ in range(args.repeats):
                    if method == "known":
                        shutil.rmtree(scratch, ignore_errors=True)
                        shutil.copytree(known, scratch)
                    t, rc = wall_time(command(args.weldtwin))
                    times.append(t)
                    if args.baseline and method != "paper":
                        base_times.append(wall_time(command(args.baseline, "baseline"))[0])
                rows.append((name, n, fmt, method, statistics.median(times), rc,
                             statistics.median(base_times) if base_times else None))
    start, _ = wall_time([args.weldtwin, "--help"])
    print(f"process start-up alone (weldtwin --help): {start:.3f} s")
    base_head = f" {'baseline s':>10} {'ratio':>6}" if args.baseline else ""
    print(f"{'sample':28} {'points':>7} {'format':>7} {'method':>6} {'median s':>9} exit{base_head}")
    for name, n, fmt, method, t, rc, b in rows:
        base = f" {b:10.3f} {t / b:6.2f}" if b else ""
        print(f"{name:28} {n:7d} {fmt:>7} {method:>6} {t:9.3f} {rc:4d}{base}")
    for fmt in ("ascii", "binary"):
        paper = [r[4] for r in rows if r[2] == fmt and r[3] == "paper" and not r[0].startswith("real")]
        for mode in ("cold", "known", "warm"):
            ours = [r[4] for r in rows if r[2] == fmt and r[3] == mode and not r[0].startswith("real")]
            if not ours:
                continue
            line = (f"{fmt} {mode}: ours median {statistics.median(ours):.3f} s, paper median "
                    f"{statistics.median(paper):.3f} s, paper/ours {statistics.median(paper) / statistics.median(ours):.2f}x")
            if args.baseline:
                base = [r[6] for r in rows if r[2] == fmt and r[3] == mode and not r[0].startswith("real")]
                line += (f"; baseline {statistics.median(base):.3f} s, "
                         f"ours/baseline {statistics.median(ours) / statistics.median(base):.2f}x")
            print(line)
            for r in rows:
                if r[0].startswith("real") and r[2] == fmt and r[3] == mode:
                    print(f"{fmt} {mode}: real scan ours {r[4]:.3f} s" +
                          (f", baseline {r[6]:.3f} s, ratio {r[4] / r[6]:.2f}x" if r[6] else ""))


if __name__ == "__main__":
    main()
