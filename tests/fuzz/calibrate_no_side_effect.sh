#!/bin/sh
# `wdrctl calibrate` without --upload changes none of the board's tables (issue 14: it left a
# pass-through table active, and after two runs the user's table was gone from both slots):
# the calibration table active before runs, a failing run (-o into a missing folder) and a
# second run is still the one active, over a restart of the board too. And --board calibrates
# the simulator even with $WDR_DEVICE set (it used to go to the board).
# usage: calibrate_no_side_effect.sh WDRCTL WDR_SIMBOARD SOURCE_DIR
set -eu
wdrctl=$1 simboard=$2 src=$3
dir=$(mktemp -d)
trap 'kill $pid 2>/dev/null || true; rm -rf "$dir"' EXIT
board="$src/boards/sim-qvga/board.json" scene="$src/sim/scenes/uniform.json"
start() {
    "$simboard" --board "$board" --scene "$scene" --socket "$dir/b.sock" --flash "$dir/flash.bin" 2>"$dir/board.log" &
    pid=$!
    "$wdrctl" info --wait 10000 >/dev/null
}
export WDR_DEVICE="sim:$dir/b.sock"
# --form compact: the table's form is not what this judges (--form auto builds and judges up to four
# forms per run; test_cal_form_auto and e2e_main_job run it)
levels="--currents 1e-13,1e-12,1e-11,1e-10,1e-9 --frames 1 --form compact"
start
"$wdrctl" lut build --board sim-qvga --operator reinhard -o "$dir/r.lut"
"$wdrctl" lut upload "$dir/r.lut" >/dev/null
# With --board, the simulator: this one runs with no board behind $WDR_DEVICE at all.
WDR_DEVICE=sim:/nonexistent/b.sock "$wdrctl" calibrate --board sim-qvga $levels -o "$dir/user.bin" >/dev/null
"$wdrctl" cal upload "$dir/user.bin" >/dev/null
active() { "$wdrctl" status | grep -i "^cal"; }
before=$(active)
echo "before: $before"
"$wdrctl" calibrate $levels -o "$dir/run1.bin" >/dev/null
[ "$(active)" = "$before" ] || { echo "FAIL: first run changed the table: $(active)"; exit 1; }
if "$wdrctl" calibrate $levels -o "$dir/missing/run2.bin" >/dev/null 2>&1; then
    echo "FAIL: writing into a missing folder succeeded"; exit 1
fi
[ "$(active)" = "$before" ] || { echo "FAIL: a failed run changed the table: $(active)"; exit 1; }
"$wdrctl" calibrate $levels -o "$dir/run3.bin" >/dev/null
[ "$(active)" = "$before" ] || { echo "FAIL: a second run changed the table: $(active)"; exit 1; }
kill $pid; wait $pid 2>/dev/null || true
start
[ "$(active)" = "$before" ] || { echo "FAIL: after a restart: $(active)"; exit 1; }
echo "after three runs and a restart: $(active)"
echo "calibrate side effects: none"
