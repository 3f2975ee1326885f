#!/bin/sh
# The README's main job on the default board, as the demo runs it, without plots:
# board up, LUT upload, calibration of the full VGA array with upload (the board back on its
# scene afterwards, no restart), corrected capture, side-by-side, then the field update (v2
# signed, uploaded, a test boot, confirmed). Fails on the first step that fails.
# usage: main_job.sh WDRCTL WDR_SIMBOARD SOURCE_DIR
set -eu
wdrctl=$1 simboard=$2 src=$3
dir=$(mktemp -d)
trap 'kill $pid 2>/dev/null || true; rm -rf "$dir"' EXIT
key="$src/firmware/boot/keys/dev-signing-key.NOT-FOR-PRODUCTION.pem"
head -c 4096 /dev/zero >"$dir/app.bin"
"$wdrctl" fw sign -k "$key" -o "$dir/v1.img" --version 1.1.0+1 --security-counter 1 "$dir/app.bin" >/dev/null
"$wdrctl" fw sign -k "$key" -o "$dir/v2.img" --version 1.2.0+2 --security-counter 2 "$dir/app.bin" >/dev/null
"$simboard" --board "$src/boards/sim-vga/board.json" --scene "$src/sim/scenes/window.json" \
    --socket "$dir/b.sock" --flash "$dir/flash.bin" --firmware "$dir/v1.img" &
pid=$!
export WDR_DEVICE="sim:$dir/b.sock"
"$wdrctl" info --wait 10000 >/dev/null
"$wdrctl" lut build --operator reinhard -o "$dir/r.lut"
"$wdrctl" lut upload "$dir/r.lut"
"$wdrctl" calibrate --lut "$dir/r.lut" --upload -o "$dir/cal.bin" --frames 1 --json >"$dir/cal.json"
"$wdrctl" status | grep -i "cal" 
"$wdrctl" capture -o "$dir/cap.pfm"
"$wdrctl" tonemap --board "$src/boards/sim-vga/board.json" --scene "$src/sim/scenes/window.json" \
    -o "$dir/soft.png" --capture "$dir/cap.pfm" --nominal "$dir/cal.json" --side-by-side "$dir/sbs.png"
"$wdrctl" fw upload "$dir/v2.img"
"$wdrctl" reboot
"$wdrctl" fw status | grep -E "^running: +v1.2.0\+2 in slot B \(test boot\)"
"$wdrctl" fw confirm
"$wdrctl" reboot
"$wdrctl" info | grep -E "^firmware: +1.2.0\+2, slot B$"
echo "main job: ok"
