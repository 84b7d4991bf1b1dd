#!/usr/bin/env bash
# A weldtwin built without its optional parts (WELDTWIN_WITH_ROSBAG, _OMPL, _OSMESA all OFF; `make
# test-without-options` builds it): it links none of them, still welds, and says in one line what it cannot do
# where that is asked for.
# Usage: without_options_test.sh WELDTWIN
set -uo pipefail
weldtwin=$1
here=$(cd "$(dirname "$0")/../.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
failed=0
fail() { echo "FAIL: $*"; failed=1; }

# None of the optional libraries is linked, by weldtwin or by weldtwin-cell beside it (every command but
# localize).
for program in "$weldtwin" "$(dirname "$weldtwin")/weldtwin-cell"; do
  [ -x "$program" ] || fail "no $program"
  linked=$(ldd "$program")
  for lib in libompl librosbag libsqlite3 libzstd libOSMesa; do
    if grep -q "$lib" <<<"$linked"; then fail "$program links $lib"; fi
  done
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

# The default cell: welded, or refused because a transit needs the joint-space search this build leaves out
# (whether the cell's own placement needs it hangs on the last digits of the pose found: on one machine the
# way home after the last seam is clear lifted, on another only a joint-space search finds it). Either way the
# report says why it has no pictures.
"$weldtwin" run -q --out "$out/run" >"$out/run.out" 2>"$out/run.err"
status=$?
if [ "$status" -ne 0 ]; then
  [ "$status" -eq 3 ] && grep -q "built without OMPL (WELDTWIN_WITH_OMPL=OFF), which searches joint space" "$out/run.err" ||
    fail "weldtwin run on the default cell: exit $status: $(tail -3 "$out/run.err")"
fi
grep -q "built without OSMesa support (WELDTWIN_WITH_OSMESA=OFF)" "$out/run/report.html" ||
  fail "the report does not say it was built without OSMesa"
[ -e "$out/run/cell_overview.png" ] && fail "the cell's pictures were drawn by a build without OSMesa"

# A layout whose ways between seams need no joint-space search (seeds 1-6 of the default cell weld without it)
# welds end to end.
"$weldtwin" run -q --seed 1 --no-renders --out "$out/seed1" >"$out/seed1.out" 2>"$out/seed1.err"
status=$?
[ "$status" -eq 0 ] || fail "weldtwin run --seed 1 on the default cell: exit $status: $(tail -3 "$out/seed1.err")"

[ "$failed" -eq 0 ] && echo "without_options_test: passed"
exit "$failed"
