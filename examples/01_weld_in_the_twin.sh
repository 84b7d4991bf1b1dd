#!/usr/bin/env bash
# 01: the whole job in the twin on the default cell: sweep, localize, plan, replay, report.
#   examples/01_weld_in_the_twin.sh            (WELDTWIN=path/to/weldtwin, OUT=dir to override)
set -euo pipefail
cd "$(dirname "$0")/.."
WELDTWIN=${WELDTWIN:-build/app/weldtwin}
OUT=${OUT:-out/examples/01}

# One command: the verdict is its last line, PASS (exit 0) or FAIL: reason (exit 3).
"$WELDTWIN" run scenes/cells/default.yaml --out "$OUT/run" --no-renders -q

# What it wrote: the sweep, the cloud, the pose, the plan, the report.
for f in scan.scanlog scan.pcd pose.json plan.json report.json report.html; do
  test -s "$OUT/run/$f" || { echo "01: $OUT/run/$f is missing" >&2; exit 1; }
done
python3 - "$OUT/run" <<'PY'
import json, sys
d = sys.argv[1]
report = json.load(open(d + "/report.json"))
pose = json.load(open(d + "/pose.json"))
assert pose["found"], pose["reason"]
assert report["verdict"] == "PASS", report["verdict"]
print("01: the part was found (seam error bound %.2f mm), planned and replayed: %s, see %s/report.html"
      % (pose["seam_error_bound_mm"], report["verdict"], d))
PY
