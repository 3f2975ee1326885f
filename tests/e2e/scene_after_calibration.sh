#!/bin/sh
# Calibration lights the simulated board uniformly; afterwards the board must see its scene
# again, whether calibration succeeded or failed (issue 22). Captures the scene before and after
# `calibrate --upload`, checks the corrected capture against the scene tone-mapped in software
# (as .ci/demo shows it), and the scene after a calibration that fails once it has lit the board;
# then `sim illuminant AMPS` and `sim illuminant scene` by hand.
# usage: scene_after_calibration.sh WDRCTL WDR_SIMBOARD SOURCE_DIR
set -eu
wdrctl=$1 simboard=$2 src=$3
board=$src/boards/sim-qvga/board.json scene=$src/sim/scenes/window.json
dir=$(mktemp -d)
trap 'kill $pid 2>/dev/null || true; rm -rf "$dir"' EXIT
"$simboard" --board "$board" --scene "$scene" --socket "$dir/b.sock" --flash "$dir/flash.bin" 2>"$dir/board.log" &
pid=$!
export WDR_DEVICE="sim:$dir/b.sock"
"$wdrctl" info --wait 10000 >/dev/null

# One frame's statistics; fails unless the codes spread over more than a flat light gives
# (uniform light spreads over ~10 codes from fixed pattern and noise; the window scene over >1000).
scene_frame() {
    line=$("$wdrctl" stream -n 1 2>/dev/null)
    echo "$1: $line"
    spread=$(echo "$line" | awk '{print $8 - $6}')
    if [ "$spread" -lt 500 ]; then
        echo "FAIL: $1: codes spread over $spread only: the board does not see its scene"
        exit 1
    fi
}

"$wdrctl" lut build --operator reinhard -o "$dir/r.lut" >/dev/null
"$wdrctl" lut upload "$dir/r.lut" >/dev/null
scene_frame "before calibrate"
"$wdrctl" calibrate --lut "$dir/r.lut" --upload -o "$dir/cal.bin" --frames 1 --json >"$dir/cal.json"
scene_frame "after calibrate --upload"
"$wdrctl" capture -o "$dir/cap.pfm" 2>/dev/null
agree=$("$wdrctl" tonemap --board "$board" --scene "$scene" -o "$dir/soft.png" --capture "$dir/cap.pfm" \
    --nominal "$dir/cal.json" --side-by-side "$dir/sbs.png" | grep "capture against software")
echo "corrected $agree"
within=$(echo "$agree" | sed 's/.*levels, \([0-9.]*\) %.*/\1/')
if ! awk -v w="$within" 'BEGIN { exit !(w >= 90) }'; then
    echo "FAIL: only $within % of the corrected capture's pixels lie within 8 levels of the software image"
    exit 1
fi

# A calibration that fails after it lit the board (its output cannot be written) restores too.
if "$wdrctl" calibrate --frames 1 -o "$dir/no/such/folder/cal.bin" >/dev/null 2>"$dir/fail.log"; then
    echo "FAIL: calibrate into a missing folder succeeded"
    exit 1
fi
scene_frame "after a failed calibrate"

"$wdrctl" sim illuminant 1e-11 >/dev/null
flat=$("$wdrctl" stream -n 1 2>/dev/null)
echo "under 1e-11 A: $flat"
"$wdrctl" sim illuminant scene
scene_frame "after sim illuminant scene"
echo "scene after calibration: ok"
