#!/usr/bin/env bash
# 04: a sweep as a ROS cell records it (sensor_msgs/LaserScan on /scan, sensor_msgs/JointState on
# /joint_states, in a ROS 2 bag with MCAP storage, rosbag2's default), handed to `weldtwin run --source log:`.
# Here the twin makes the recording; a real cell's bag goes the same way.
set -euo pipefail
cd "$(dirname "$0")/.."
WELDTWIN=${WELDTWIN:-build/app/weldtwin}
OUT=${OUT:-out/examples/04}
rm -rf "$OUT" && mkdir -p "$OUT"
CELL=scenes/cells/default.yaml

"$WELDTWIN" scan "$CELL" --out "$OUT/scan.scanlog" --rosbag2 "$OUT/bag" --rosbag2-storage mcap -q
ls "$OUT/bag"/*.mcap >/dev/null
"$WELDTWIN" run "$CELL" --source "log:$OUT/bag" --out "$OUT/run" --no-renders -q
echo "04: the recorded sweep localized, planned and replayed: PASS ($OUT/run/report.html)"
