#!/bin/sh
# `wdrctl stream --v4l2` writes the frames a V4L2 reader gets, pixel for pixel as `wdrctl capture`
# writes them (issue 22): a simulated board on the noiseless log_wedge scene (every frame the
# same), 3 frames streamed into a regular file in each format (GREY: the display image; Y16: the
# corrected codes), compared with a capture of the board. tests/vm does the same through a real
# v4l2loopback device.
# usage: stream_v4l2.sh WDRCTL WDR_SIMBOARD V4L2_COMPARE
set -u
wdrctl=$1 simboard=$2 compare=$3
dir=$(mktemp -d)
pid=
trap '[ -n "$pid" ] && kill $pid 2>/dev/null; rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
"$simboard" --board sim-qvga --scene log_wedge --socket "$dir/b.sock" 2>"$dir/board.log" &
pid=$!
export WDR_DEVICE="sim:$dir/b.sock"
"$wdrctl" info --wait 10000 >/dev/null || fail "no board"
"$wdrctl" lut build --board sim-qvga --operator reinhard -o "$dir/r.lut" >/dev/null
"$wdrctl" lut upload "$dir/r.lut" >/dev/null
"$wdrctl" capture -o "$dir/grey.png" --bits 8 --negate 2>/dev/null || fail "capture"
"$wdrctl" capture -o "$dir/y16.png" --raw 2>/dev/null || fail "capture --raw"
for fmt in grey y16; do
    "$wdrctl" stream -n 3 --v4l2 "$dir/$fmt.raw" --format $fmt >/dev/null 2>"$dir/stream.log" ||
        fail "stream --v4l2: $(cat "$dir/stream.log")"
    sed 's/^/  /' "$dir/stream.log"
    bpp=1
    [ $fmt = y16 ] && bpp=2
    "$compare" $fmt 160 120 $((160 * bpp)) "$dir/$fmt.raw" 3 "$dir/$fmt.png" || fail "$fmt frames differ from the capture"
done
"$wdrctl" stream -n 1 --fps 5 >/dev/null 2>&1 && fail "--fps without --v4l2 accepted"
"$wdrctl" stream -n 1 --v4l2 /dev/null/x >/dev/null 2>"$dir/err.log" && fail "an unopenable --v4l2 path accepted"
grep -q "cannot open" "$dir/err.log" || fail "no message for an unopenable device: $(cat "$dir/err.log")"
echo "stream v4l2: ok"
