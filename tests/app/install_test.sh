#!/bin/bash
# `cmake --install` lays out a tree that works on its own: weldtwin run from it (in another directory) finds the
# installed scenes and welds the default cell; the installed binary (stripped: debug builds name their sources)
# holds no path of the checkout; WELDTWIN_SCENES names other scenes, and a wrong one is a clear error (exit 2).
#   install_test.sh BUILD_DIR SOURCE_DIR
set -u
build=$1
source_dir=$2
prefix=$(mktemp -d /tmp/weldtwin_install_XXXXXX)
trap 'rm -rf "$prefix"' EXIT
fail() { echo "install_test: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$prefix/usr" --strip >"$prefix/install.log" 2>&1 || { cat "$prefix/install.log"; fail "cmake --install failed"; }
exe=$prefix/usr/bin/weldtwin
[ -x "$exe" ] || fail "no $exe after the install"
[ -f "$prefix/usr/share/weldtwin/scenes/cells/default.yaml" ] || fail "the scenes were not installed"
[ -L "$prefix/usr/share/weldtwin/scenes" ] && fail "the installed scenes are a link into the checkout"
cell=$prefix/usr/bin/weldtwin-cell  # every command but localize, which weldtwin hands them to
[ -x "$cell" ] || fail "no $cell after the install"
for f in "$exe" "$cell"; do
  if grep -q -a -F "$source_dir" "$f"; then fail "the installed $f holds the checkout's path $source_dir"; fi
done
# A localization loads what it needs, not the cell's simulator, planners and robot driver.
for lib in libmujoco libompl librosbag; do
  if ldd "$exe" | grep -q "$lib"; then fail "the installed weldtwin links $lib: localize would load it"; fi
done

# Run from the install tree, elsewhere, with the installed scenes only.
cd "$prefix"
"$exe" run --seed 1 --out "$prefix/out" --no-renders --no-guidance -q --threads 2 >"$prefix/run.log" 2>&1
code=$?
[ "$code" = 0 ] || { cat "$prefix/run.log"; fail "weldtwin run from the install tree exited $code"; }
grep -q '"verdict": "PASS"' "$prefix/out/report.json" || fail "no PASS in the installed run's report.json"
grep -q "$prefix/usr/share/weldtwin/scenes/cells/default.yaml" "$prefix/out/report.json" ||
  fail "the installed run did not use the installed default cell"

# WELDTWIN_SCENES: another scenes directory is used; a missing one is named, exit 2.
cp -r "$prefix/usr/share/weldtwin/scenes" "$prefix/other_scenes"
WELDTWIN_SCENES=$prefix/other_scenes "$exe" --help | grep -q "$prefix/other_scenes" ||
  fail "--help does not name the scenes WELDTWIN_SCENES gives"
WELDTWIN_SCENES=$prefix/nowhere "$exe" run --out "$prefix/bad" -q >"$prefix/bad.log" 2>&1
code=$?
[ "$code" = 2 ] || { cat "$prefix/bad.log"; fail "a missing WELDTWIN_SCENES exited $code, not 2"; }
grep -q "WELDTWIN_SCENES=$prefix/nowhere" "$prefix/bad.log" || { cat "$prefix/bad.log"; fail "the error does not name WELDTWIN_SCENES"; }
echo "install_test: the install tree runs on its own"
