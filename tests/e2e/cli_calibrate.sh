#!/bin/sh
# `wdrctl calibrate --device` on wdr-simboard (issue 19, items 2 and 7):
# 1. the global --wait finds a board that starts a second after calibrate, and one connection
#    serves the whole run (LUT, probe, levels, verification, upload): a `--once` board, which
#    ends when its first host disconnects, sees it through; a clean chip flags 0 pixels;
# 2. a board with no LUT is refused up front: exit 78, "no LUT on the board: upload one or give --lut";
#    --lut of one operator with --operator of another is refused (exit 64) before anything is uploaded;
# 3. --max-flagged on a chip with 8 planted defects (the scene's "defects": 2 each of dead, hot,
#    stuck, saturated; one among the pixels the selection samples): all 8 and no other flagged;
#    --max-flagged 8 passes and uploads; the default (100 ppm: 1.92 pixels of 19,200) fails with
#    exit 65 and the count by kind, writes no table and uploads none (STATUS: the previous table
#    stays active); the summary and the verification say how many pixels they left out.
# usage: cli_calibrate.sh WDRCTL WDR_SIMBOARD SOURCE_DIR
set -u
wdrctl=$1 simboard=$2 src=$3
board=$src/boards/sim-qvga/board.json scene=$src/sim/scenes/window.json
dir=$(mktemp -d)
pids=""
trap 'for p in $pids; do kill "$p" 2>/dev/null; done; rm -rf "$dir"' EXIT
fail() {
    echo "FAIL: $*"
    for f in "$dir"/*.err "$dir"/*.log; do [ -s "$f" ] && { echo "--- $f"; cat "$f"; }; done
    exit 1
}
"$wdrctl" lut build --operator reinhard -o "$dir/r.lut" >/dev/null || fail "lut build"

# ---- 1. --wait, and one connection for the whole run ----
export WDR_DEVICE="sim:$dir/once.sock"
"$wdrctl" --wait 20000 calibrate --lut "$dir/r.lut" --upload --json --frames 2 -o "$dir/once.bin" \
    >"$dir/once.json" 2>"$dir/once.err" &
cal=$!
sleep 1 # the board is not there yet: without --wait calibrate exits 69 at once
"$simboard" --board "$board" --scene "$scene" --socket "$dir/once.sock" --flash "$dir/once.flash" --once \
    2>"$dir/once.log" &
once=$!
pids="$once"
wait "$cal"
rc=$?
[ "$rc" -eq 0 ] || fail "calibrate --wait on a board starting 1 s later, --once: exit $rc"
grep -q '"verification"' "$dir/once.json" || fail "--once: the run ended before its verification"
grep -q "calibration table uploaded and active" "$dir/once.err" || fail "--once: no upload"
wait "$once" || fail "the --once board did not end cleanly"
grep "stopped after" "$dir/once.log"
flagged=$(sed -n 's/^[[:space:]]*"pixels_flagged":[[:space:]]*\([0-9]*\).*/\1/p' "$dir/once.json" | head -n 1)
[ "$flagged" = 0 ] || fail "a clean chip flagged $flagged pixels"
grep -q '"within":[[:space:]]*true' "$dir/once.json" || fail "--json lacks max_flagged within: true"
# --form auto (the default) on a simulated board: judged on fresh frames the board lit, its choice
# in the JSON and on stderr
grep -q '"frames":[[:space:]]*"fresh"' "$dir/once.json" || fail "--json lacks form_auto judged on fresh frames"
grep -q "^form auto: [a-z]* chosen" "$dir/once.err" || fail "no form auto choice printed"
echo "ok: --wait found a board starting 1 s late; one connection served calibrate --lut --upload --json on a --once board; 0 flagged"

# ---- 2. no LUT on the board ----
sed 's/"effects": {},/"effects": {}, "defects": { "pixels": [ {"x": 10, "y": 10, "kind": "dead"}, {"x": 140, "y": 46, "kind": "dead"}, {"x": 11, "y": 90, "kind": "hot"}, {"x": 100, "y": 60, "kind": "hot"}, {"x": 150, "y": 5, "kind": "stuck"}, {"x": 3, "y": 110, "kind": "stuck"}, {"x": 77, "y": 33, "kind": "saturated"}, {"x": 120, "y": 100, "kind": "saturated"} ] },/' \
    "$scene" >"$dir/defects.json"
grep -q '"defects"' "$dir/defects.json" || fail "the defects scene was not made"
export WDR_DEVICE="sim:$dir/d.sock"
"$simboard" --board "$board" --scene "$dir/defects.json" --socket "$dir/d.sock" --flash "$dir/d.flash" \
    2>"$dir/d.log" &
pids="$pids $!"
"$wdrctl" --wait 10000 info >/dev/null || fail "the defects board did not start"
# a LUT built for one operator and --operator naming another: refused before anything reaches the
# board (the no-LUT check below then proves that nothing was uploaded)
"$wdrctl" calibrate --lut "$dir/r.lut" --operator drago --frames 2 -o "$dir/mismatch.bin" >/dev/null 2>"$dir/mismatch.err"
rc=$?
cat "$dir/mismatch.err"
[ "$rc" -eq 64 ] || fail "--lut reinhard --operator drago: exit $rc, expected 64"
grep -q "operator drago, but .*r.lut was built for reinhard" "$dir/mismatch.err" || fail "operator mismatch: the message does not name both"
[ ! -e "$dir/mismatch.bin" ] || fail "operator mismatch: a table was written"
"$wdrctl" calibrate --frames 2 -o "$dir/nolut.bin" >/dev/null 2>"$dir/nolut.err"
rc=$?
cat "$dir/nolut.err"
[ "$rc" -eq 78 ] || fail "no LUT: exit $rc, expected 78"
grep -q "no LUT on the board: upload one or give --lut" "$dir/nolut.err" || fail "no LUT: the message does not say so"
echo "ok: no LUT: exit 78 and the reason"

# ---- 3. --max-flagged ----
"$wdrctl" lut upload "$dir/r.lut" >/dev/null || fail "lut upload"
"$wdrctl" calibrate --frames 2 --form compact --max-flagged 8 --upload -o "$dir/pass.bin" --json >"$dir/pass.json" 2>"$dir/pass.err"
rc=$?
[ "$rc" -eq 0 ] || fail "--max-flagged 8 with 8 planted defects: exit $rc"
flagged=$(sed -n 's/^[[:space:]]*"pixels_flagged":[[:space:]]*\([0-9]*\).*/\1/p' "$dir/pass.json" | head -n 1)
[ "$flagged" = 8 ] || fail "8 defects planted, $flagged pixels flagged"
grep -q '"given":[[:space:]]*"8"' "$dir/pass.json" || fail "--json lacks max_flagged given 8"
grep -q '"pixels_left_out_after_table"' "$dir/pass.json" || fail "--json verification lacks pixels_left_out_after_table"
left=$(tr -d ' \t\n' <"$dir/pass.json" | sed -n 's/.*"pixels_left_out_after_table":\[\([0-9,]*\)\].*/\1/p')
echo "verification after table, pixels left out per current: $left"
echo "$left" | tr ',' '\n' | awk '$1 < 8 { bad = 1 } END { exit bad }' ||
    fail "the verification left out fewer pixels than the 8 flagged: $left"
crc=$("$wdrctl" status --json | tr -d ' \t\n' | sed -n 's/.*"calibration":{[^}]*"crc":"\([0-9a-f]*\)".*/\1/p')
[ -n "$crc" ] && [ "$crc" != 00000000 ] || fail "--max-flagged 8: no calibration table active (crc '$crc')"
echo "ok: 8 planted, 8 flagged: --max-flagged 8 passes and uploads (calibration crc $crc)"

"$wdrctl" calibrate --frames 2 --upload -o "$dir/fail.bin" >"$dir/fail.out" 2>"$dir/fail.err"
rc=$?
cat "$dir/fail.out" "$dir/fail.err"
[ "$rc" -eq 65 ] || fail "default --max-flagged (100 ppm) with 8 flagged: exit $rc, expected 65"
grep -q "8 of 19200 pixels flagged.*more than --max-flagged 100ppm" "$dir/fail.err" || fail "the failure lacks the count"
grep -q "dead [0-9]*, stuck [0-9]*, hot [0-9]*, saturated [0-9]*, unfit [0-9]*" "$dir/fail.err" ||
    fail "the failure lacks the count by kind"
grep -q "8 of 19200 pixels flagged" "$dir/fail.out" || fail "the summary lacks the flagged count"
# the dead pixel at (140, 46) is pixel 7500, one of the 256 the selection samples (every 75th)
grep -q "worst contrast error at selection: .*([^)]* [1-9][0-9]* of them flagged and left out)" "$dir/fail.out" ||
    fail "the summary's contrast error does not say how many pixels it left out (a planted one among them)"
[ ! -e "$dir/fail.bin" ] || fail "a table was written although the flag limit failed"
now=$("$wdrctl" status --json | tr -d ' \t\n' | sed -n 's/.*"calibration":{[^}]*"crc":"\([0-9a-f]*\)".*/\1/p')
[ "$now" = "$crc" ] || fail "the board's calibration table changed ($crc -> $now) although the flag limit failed"
echo "ok: over the limit: exit 65, the count by kind, no table written, the board keeps table $crc"

"$wdrctl" calibrate --frames 2 --max-flagged 5x -o "$dir/x.bin" 2>"$dir/bad.err"
rc=$?
[ "$rc" -eq 64 ] && grep -q "option --max-flagged: '5x'" "$dir/bad.err" || fail "--max-flagged 5x: exit $rc"

# ---- 4. the board file is the board's own ----
# Sections 1 and 3 give no --board: the file is the one the board names (sim-qvga). Another
# board's file is refused before anything is measured or changed: sim-vga's geometry put 4x the
# read delay and another chip's hold leak into the LUT's exposure block.
"$wdrctl" calibrate --device "$WDR_DEVICE" --board sim-vga --frames 2 --lut "$dir/r.lut" --upload -o "$dir/vga.bin" 2>"$dir/vga.err"
rc=$?
cat "$dir/vga.err"
[ "$rc" -eq 78 ] || fail "--board sim-vga on a sim-qvga board: exit $rc, expected 78"
grep -q "board file 'sim-vga' (640x480.*does not describe the board at .*('sim-qvga', 160x120.*field geometry.width differs" \
    "$dir/vga.err" || fail "--board sim-vga on a sim-qvga board: the message does not name the field and both boards"
now=$("$wdrctl" status --json | tr -d ' \t\n' | sed -n 's/.*"calibration":{[^}]*"crc":"\([0-9a-f]*\)".*/\1/p')
[ "$now" = "$crc" ] && [ ! -e "$dir/vga.bin" ] || fail "a refused board file changed the board's tables or wrote one"
echo "ok: another board's file is refused: exit 78, the field named, the board keeps its tables"
echo "calibrate on the board: ok"
