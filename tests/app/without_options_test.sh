#!/usr/bin/env bash
# A weldtwin built without its optional parts (WELDTWIN_WITH_ROSBAG, _OMPL, _OSMESA all OFF; `make
# test-without-options` builds it): it links none of them, still welds the default cell, and says in one line
# what it cannot do where that is asked for.
# Usage: without_options_test.sh WELDTWIN
set -uo pipefail
weldtwin=$1
here=$(cd "$(dirname "$0")/../.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
failed=0
fail() { echo "FAIL: $*"; failed=1; }

# None of the optional libraries is linked.
linked=$(ldd "$weldtwin")
for lib in libompl librosbag libsqlite3 libzstd libOSMesa; do
  if grep -q "$lib" <<<"$linked"; then fail "$weldtwin links $lib"; fi
done

# A ROS bag, read: exit 2, one line naming the bag and the option.
"$weldtwin" run -q --no-renders --source "log:$here/tests/data/rosbag2_talker_mcap" --out "$out/bag" \
  >"$out/bag.out" 2>"$out/bag.err"
status=$?
[ "$status" -eq 2 ] || fail "reading a ROS bag: exit $status, not 2"
grep -q "rosbag2_talker_mcap.*built without ROS bag support (WELDTWIN_WITH_ROSBAG=OFF)" "$out/bag.err" ||
  fail "reading a ROS bag: no line naming the bag and the option: $(cat "$out/bag.err")"

# A ROS bag, written: the same.
"$weldtwin" scan -q "$here/scenes/cells/default.yaml" --rosbag "$out/sweep.bag" --out "$out/sweep.scanlog" >"$out/scan.out" 2>"$out/scan.err"
status=$?
[ "$status" -eq 2 ] || fail "writing a ROS bag: exit $status, not 2"
grep -q "sweep.bag.*built without ROS bag support" "$out/scan.err" ||
  fail "writing a ROS bag: no line naming it: $(cat "$out/scan.err")"

# The default cell still welds (no joint-space search needed there); the report says why it has no pictures.
"$weldtwin" run -q --out "$out/run" >"$out/run.out" 2>"$out/run.err"
status=$?
[ "$status" -eq 0 ] || fail "weldtwin run on the default cell: exit $status: $(tail -3 "$out/run.err")"
grep -q "built without OSMesa support (WELDTWIN_WITH_OSMESA=OFF)" "$out/run/report.html" ||
  fail "the report does not say it was built without OSMesa"
[ -e "$out/run/cell_overview.png" ] && fail "the cell's pictures were drawn by a build without OSMesa"

[ "$failed" -eq 0 ] && echo "without_options_test: passed"
exit "$failed"
