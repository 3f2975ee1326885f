#!/bin/sh
# cmake --install to a staging folder (DESTDIR), list what it installed, then
# `systemd-analyze verify` the staged wdr-board.service with its commands pointed at the staged
# programs (verify checks that they exist). Exit 77 (skip) without systemd-analyze.
#   unit_verify.sh BUILD_DIR PREFIX UNIT_DIR
build=$1 prefix=$2 unit_dir=$3 stage=$1/stage
command -v systemd-analyze >/dev/null || { echo "SKIP: no systemd-analyze (Debian package systemd)"; exit 77; }
rm -rf "$stage"
DESTDIR=$stage cmake --install "$build" >/dev/null || exit 1
(cd "$stage" && find . -type f | sort)
case $unit_dir in /*) unit=$stage$unit_dir/wdr-board.service ;; *) unit=$stage$prefix/$unit_dir/wdr-board.service ;; esac
[ -f "$unit" ] || { echo "FAIL: no $unit"; exit 1; }
[ -x "$stage$prefix/bin/wdr-gadget" ] && [ -x "$stage$prefix/bin/wdr-board" ] || { echo "FAIL: wdr-gadget or wdr-board not installed"; exit 1; }
mkdir -p "$build/stage-check"
sed "s#$prefix/bin/#$stage$prefix/bin/#" "$unit" >"$build/stage-check/wdr-board.service"
out=$(systemd-analyze --man=no verify "$build/stage-check/wdr-board.service" 2>&1)
rc=$?
echo "systemd-analyze verify: exit $rc${out:+: $out}"
[ $rc -eq 0 ] && [ -z "$out" ]
