#!/bin/sh
# Issue 19 item 5: `wdrctl calibrate --json` on a simulated board whose scene plants defects at
# given positions counts each kind as planted (one kind per pixel, host/cal/cal_bad.c), and the
# text summary says the same. Four of each kind on sim-qvga (160x120); the stuck voltages this
# seed draws lie away from the dark level (a stuck node held there reads as dead). --max-flagged
# 16: the 16 planted pixels are over the default limit of 100 ppm (1.92 pixels here).
# usage: calibrate_defect_kinds.sh WDRCTL WDR_SIMBOARD SOURCE_DIR
set -eu
wdrctl=$1 simboard=$2 src=$3
board=$src/boards/sim-qvga/board.json
dir=$(mktemp -d)
trap 'kill $pid 2>/dev/null || true; rm -rf "$dir"' EXIT
pixels=""
for kind in dead stuck hot saturated; do
    for k in 0 1 2 3; do
        case $kind in dead) y=10 ;; stuck) y=40 ;; hot) y=70 ;; *) y=100 ;; esac
        pixels="$pixels{\"x\": $((20 + 37 * k)), \"y\": $((y + k)), \"kind\": \"$kind\"},"
    done
done
cat >"$dir/scene.json" <<JSON
{ "format": "wdrcam-scene", "version": 1, "comment": "window scene, 16 planted defects",
  "illumination": { "pattern": "window", "l_min": 1e-3, "l_max": 1e3, "window": [0.55, 0.15, 0.85, 0.6] },
  "lum_to_amp": 1e-11, "exposure": 1.0, "reference": false, "effects": {}, "chip_seed": 1, "frame_seed": 1,
  "defects": { "seed": 5, "pixels": [${pixels%,}] } }
JSON
"$simboard" --board "$board" --scene "$dir/scene.json" --socket "$dir/b.sock" --flash "$dir/flash.bin" \
    2>"$dir/board.log" &
pid=$!
export WDR_DEVICE="sim:$dir/b.sock"
"$wdrctl" info --wait 10000 >/dev/null
"$wdrctl" lut build --operator reinhard -o "$dir/r.lut" >/dev/null
"$wdrctl" calibrate --lut "$dir/r.lut" -o "$dir/cal.bin" --frames 4 --max-flagged 16 --json >"$dir/cal.json" 2>"$dir/cal.log"
got=$(jq -c '.flags' "$dir/cal.json")
echo "flags by kind: $got (pixels_flagged $(jq .pixels_flagged "$dir/cal.json"))"
want='{"dead":4,"stuck":4,"hot":4,"saturated":4,"unfit":0}'
if [ "$got" != "$want" ]; then
    echo "FAIL: want $want"
    exit 1
fi
echo "defect kinds: ok"
