#!/bin/sh
# usage: cli_calibrate_noise.sh WDRCTL OUTDIR
# `wdrctl calibrate --noise on` on a simulated QVGA chip (converters and temporal noise on, the
# defaults otherwise): no pixel flagged, and --frames auto prints the frames it chose, more than
# two (it never takes fewer than two, the probe's count, so more than one would hold without noise); `--noise off` says so in its verification; `--noise bogus` is refused with exit 64 and a
# message naming the option and the value.
ctl=$1; out=$2
mkdir -p "$out" || exit 1
fail() { echo "FAIL: $*"; exit 1; }

log=$("$ctl" calibrate --board sim-qvga --noise on -o "$out/noise_on.bin" --json 2>"$out/noise_on.err"); rc=$?
cat "$out/noise_on.err"
printf '%s\n' "$log" | grep -E '"(pixels_flagged|frames_per_level|holds_with)"'
[ "$rc" -eq 0 ] || fail "--noise on: exit $rc"
flagged=$(printf '%s\n' "$log" | sed -n 's/^[[:space:]]*"pixels_flagged":[[:space:]]*\([0-9]*\).*/\1/p')
[ "$flagged" = 0 ] || fail "--noise on: $flagged pixels flagged, expected 0"
frames=$(sed -n 's/.*--frames auto: \([0-9]*\) frames per level.*/\1/p' "$out/noise_on.err")
[ -n "$frames" ] || fail "--noise on: the frames --frames auto chose are not printed"
[ "$frames" -gt 2 ] || fail "--noise on: --frames auto chose $frames frames, expected more than 2 (noise measured)"
printf '%s\n' "$log" | grep -q '"frames_per_level":[[:space:]]*'"$frames"',' || fail "--json frames_per_level is not $frames"
printf '%s\n' "$log" | grep -q '"holds_with":[[:space:]]*"[^"]*temporal noise on"' || fail "--noise on: verification says otherwise"

log=$("$ctl" calibrate --board sim-qvga --noise off -o "$out/noise_off.bin" --json 2>/dev/null) || fail "--noise off failed"
printf '%s\n' "$log" | grep -q '"holds_with":[[:space:]]*"[^"]*temporal noise off"' || fail "--noise off: verification says otherwise"

msg=$("$ctl" calibrate --board sim-qvga --noise bogus -o "$out/bogus.bin" 2>&1); rc=$?
echo "$msg"
[ "$rc" -eq 64 ] || fail "--noise bogus: exit $rc, expected 64"
printf '%s\n' "$msg" | grep -q -- "option --noise: unknown value 'bogus'" || fail "--noise bogus: message lacks option and value"
echo "ok: --noise on flags 0 pixels with $frames frames per level (auto); --noise bogus refused (64)"
