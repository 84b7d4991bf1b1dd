#!/usr/bin/env bash
# 05: the robot gate. With `--robot aubo://HOST` and without `--execute`, a run ends in a dry run: every request
# the Aubo controller would get (login with the password masked, the path buffer with every waypoint, the run
# command) in robot_dry_run.json; nothing is sent. 192.0.2.1 is a documentation address: nothing is there.
# `--execute` would send the plan only if this run's replay passed (docs/hardware.md).
set -euo pipefail
cd "$(dirname "$0")/.."
WELDTWIN=${WELDTWIN:-build/app/weldtwin}
OUT=${OUT:-out/examples/05}

"$WELDTWIN" run scenes/cells/default.yaml --robot aubo://192.0.2.1 --out "$OUT/run" --no-renders -q
python3 - "$OUT/run" <<'PY'
import json, sys
d = sys.argv[1]
dry = json.load(open(d + "/robot_dry_run.json"))
plan = json.load(open(d + "/plan.json"))
methods = [r["method"] for r in dry["requests"]]
assert methods[-1].endswith("MotionControl.movePathBuffer"), methods[-1]
waypoints = sum(len(r["params"][1]) for r in dry["requests"] if r["method"].endswith("pathBufferAppend"))
assert waypoints == dry["samples"], (waypoints, dry["samples"])
login = [r for r in dry["requests"] if r["method"] == "__login__"]
assert login and login[0]["params"][1] == "***", "the password is not masked"
print("05: dry run of %d requests, %d waypoints (%.1f s) for %s: nothing sent"
      % (len(methods), waypoints, dry["duration_s"], dry["robot"]))
PY
