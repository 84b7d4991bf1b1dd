#!/usr/bin/env bash
# 03: the job one command at a time, with the files between them, as a cell that records its sweep elsewhere
# would run it: sweep -> cloud -> pose -> plan -> replay.
set -euo pipefail
cd "$(dirname "$0")/.."
WELDTWIN=${WELDTWIN:-build/app/weldtwin}
OUT=${OUT:-out/examples/03}
mkdir -p "$OUT"
CELL=scenes/cells/default.yaml
PART=scenes/parts/tube_on_plate.yaml

# The sweep (ScanLog) and the base-frame cloud with every point's viewpoint.
"$WELDTWIN" scan "$CELL" --out "$OUT/scan.scanlog" --cloud "$OUT/scan.pcd" -q
# Find the part: the spec names its mesh and its seams (the seam error bound is at the seams).
"$WELDTWIN" localize --part "$PART" --scan "$OUT/scan.pcd" --out "$OUT/pose.json" -q
# Plan every seam at that pose, against the cell's table, clamps and clutter.
"$WELDTWIN" plan --part "$PART" --pose "$OUT/pose.json" --cell "$CELL" --out "$OUT/plan.json" --csv "$OUT/plan.csv" -q
# Judge the plan in the twin: exit 0 when it passes.
"$WELDTWIN" replay "$OUT/plan.json" "$CELL" --out "$OUT/replay" --no-renders -q
head -1 "$OUT/plan.csv" | grep -q '^t,j1,j2,j3,j4,j5,j6' || { echo "03: plan.csv has no header" >&2; exit 1; }
echo "03: scan, localize, plan, replay: PASS ($OUT/replay/report.html)"
