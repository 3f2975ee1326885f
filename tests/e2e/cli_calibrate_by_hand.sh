#!/bin/sh
# `wdrctl calibrate --device` on a board that cannot light itself, as a real one (issue 21 item 2,
# the path no self-lit simulated board reaches): wdr-simboard --light-by-hand FILE reports no
# illuminant and reads a lab light from FILE at each frame; the "person" below waits for each of
# wdrctl's prompts, sets the light it asks for in FILE, and presses Enter.
# 1. The board acts real: `wdrctl sim illuminant` is refused, and calibrate without the levels is
#    refused up front (exit 64, "sets no light itself").
#    With the LUT as `lut upload` left it (no margin sized), calibrate fails naming --lut.
# 2. A self-lit board on the same chip and scene picks the currents (the probe) and judges
#    --form auto on fresh frames: its choice and every form's figure.
# 3. By hand, with those currents: one prompt per light (the margin's probe, the dark frame, each
#    level, each of the 31 currents --form auto judges on), no other; the person told of the 31
#    first; and the same forms tried, the same verdicts and the same choice as self-lit.
#    Seen failing with the forms judged in-sample on the calibration levels (18 prompts; every form
#    rejected, basis-8, where the self-lit board chose compact).
# usage: cli_calibrate_by_hand.sh WDRCTL WDR_SIMBOARD SOURCE_DIR [OPERATOR [SEED [FRAMES]]]
set -u
wdrctl=$1 simboard=$2 src=$3 op=${4:-reinhard} seed=${5:-1} frames=${6:-8}
board=$src/boards/sim-qvga/board.json scene=$src/sim/scenes/window.json
dir=$(mktemp -d)
pids=""
trap 'for p in $pids; do kill "$p" 2>/dev/null; done; rm -rf "$dir"' EXIT
fail() {
    echo "FAIL: $*"
    for f in "$dir"/*.err "$dir"/*.log; do [ -s "$f" ] && { echo "--- $f"; tail -n 40 "$f"; }; done
    exit 1
}
json_field() { # FILE FIELD: a string or number field's first value
    tr -d '\n' <"$1" | sed -n "s/.*\"$2\":[[:space:]]*\"*\([^\",}]*\).*/\1/p" | head -n 1
}
form_rank() { # smallest table first, as --form auto tries them
    case "$1" in compact) echo 1 ;; shifted) echo 2 ;; poly) echo 3 ;; basis) echo 4 ;; *) echo 0 ;; esac
}
"$wdrctl" lut build --operator "$op" -o "$dir/op.lut" >/dev/null || fail "lut build"

# ---- 2. the self-lit board: the currents, and auto on fresh frames ----
start_board() { # NAME [OPTIONS]: a fresh board on the same chip and scene, and its LUT uploaded
    name=$1
    shift
    export WDR_DEVICE="sim:$dir/$name.sock"
    "$simboard" --board "$board" --scene "$scene" --seed "$seed" --socket "$dir/$name.sock" "$@" 2>"$dir/$name.log" &
    pids="$pids $!"
    "$wdrctl" --wait 10000 lut upload "$dir/op.lut" >/dev/null || fail "board $name: lut upload"
}
start_board probe
# The LUT as `lut upload` left it has no margin sized for this chip: its latest crossers stay flat
# at the dim end (144-148 of 19,200 here), and the failure says what to do.
"$wdrctl" calibrate --frames "$frames" -o "$dir/nomargin.bin" 2>"$dir/nomargin.err"
rc=$?
[ "$rc" -eq 65 ] && grep -q "flat response.*give --lut FILE, and calibrate sizes it" "$dir/nomargin.err" ||
    fail "calibrate with the uploaded LUT's margin: exit $rc, no hint to give --lut"
"$wdrctl" calibrate --lut "$dir/op.lut" --frames "$frames" --json -o "$dir/probe.bin" >"$dir/probe.json" \
    2>"$dir/probe.err" || fail "self-lit calibrate (the probe's currents)"
currents=$(tr -d ' \t\n' <"$dir/probe.json" | sed -n 's/.*"currents_A":\[\([^]]*\)\].*/\1/p')
[ -n "$currents" ] || fail "the self-lit run gave no currents"
# A fresh board, given the currents as the board by hand will be: the same frames in the same order.
start_board lit
"$wdrctl" calibrate --lut "$dir/op.lut" --currents "$currents" --frames "$frames" --json -o "$dir/lit.bin" \
    >"$dir/lit.json" 2>"$dir/lit.err" || fail "self-lit calibrate"
lit_form=$(json_field "$dir/lit.json" form)
[ -n "$lit_form" ] || fail "the self-lit run gave no form"
grep "^form auto:" "$dir/lit.err"
echo "self-lit ($op, seed $seed): currents $currents; form auto on fresh frames: $lit_form"

# ---- 1. the board by hand acts as a real one ----
light=$dir/light
echo scene >"$light"
start_board hand --light-by-hand "$light"
"$wdrctl" info | grep -q "simulated: *no" || fail "the board by hand still says it is simulated"
"$wdrctl" sim illuminant 1e-10 2>"$dir/refused.err" && fail "the board by hand let wdrctl light it"
"$wdrctl" calibrate --frames "$frames" -o "$dir/none.bin" 2>"$dir/nolevels.err"
rc=$?
[ "$rc" -eq 64 ] && grep -q "sets no light itself" "$dir/nolevels.err" || fail "no levels given: exit $rc"
echo "ok: the board by hand refuses to be lit, and calibrate without levels is refused (exit 64)"

# ---- 3. by hand: the person answers each prompt ----
mkfifo "$dir/enter"
"$wdrctl" calibrate --lut "$dir/op.lut" --currents "$currents" --frames "$frames" --json \
    -o "$dir/hand.bin" <"$dir/enter" >"$dir/hand.json" 2>"$dir/hand.err" &
cal=$!
exec 3>"$dir/enter"
answered=0
while kill -0 "$cal" 2>/dev/null; do
    asked=$(grep -o "press Enter" "$dir/hand.err" | wc -l)
    if [ "$asked" -gt "$answered" ]; then
        amps=$(grep -o "giving [^ ]* A per pixel" "$dir/hand.err" | sed -n "${asked}p" | cut -d' ' -f2)
        echo "$amps" >"$light.new" && mv "$light.new" "$light" # the person sets the light,
        echo >&3                                              # then presses Enter
        answered=$asked
    fi
    sleep 0.05
done
exec 3>&-
wait "$cal"
rc=$?
[ "$rc" -eq 0 ] || fail "calibrate by hand: exit $rc"
n_levels=$(echo "$currents" | tr ',' '\n' | wc -l)
# the margin's probe (1e-14 and 1e-08 A), the dark frame, each level, then the 31 judged currents
expected=$((2 + 1 + n_levels + 31))
[ "$answered" -eq "$expected" ] ||
    fail "$answered prompts, not $expected (the margin's 2, the dark frame, $n_levels levels, 31 judged)"
grep -q "giving 0 A per pixel (0: cover the sensor)" "$dir/hand.err" || fail "the dark frame was never asked for"
grep -q "form auto: judging the table forms takes 31 more lights" "$dir/hand.err" ||
    fail "the person was not told the judging's 31 lights before they were asked for"
[ -s "$dir/hand.bin" ] || fail "calibrate by hand wrote no table"
hand_form=$(json_field "$dir/hand.json" form)
echo "by hand: $answered prompts answered; form auto: $hand_form (self-lit: $lit_form)"
verdicts() { grep -o "form auto: [a-z]* \(chosen\|rejected\)" "$1"; }
verdicts "$dir/hand.err" >"$dir/hand.forms"
verdicts "$dir/lit.err" >"$dir/lit.forms"
[ -s "$dir/hand.forms" ] || fail "calibrate by hand printed no form it tried"
# The same chip, lit the same way: the same forms tried, the same verdicts. (The figures differ in
# their third digit: the light a person sets is taken at the ramp's start.) Judged in-sample on its
# levels, a real board got basis-8 where the self-lit one chose compact.
cmp -s "$dir/hand.forms" "$dir/lit.forms" ||
    { diff "$dir/lit.forms" "$dir/hand.forms"; fail "by hand, the forms were judged otherwise than self-lit"; }
[ "$hand_form" = "$lit_form" ] || fail "by hand $hand_form, self-lit $lit_form"
echo "calibrate by hand: ok"
