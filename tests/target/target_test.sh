#!/bin/sh
# The firmware image on an emulated Cortex-M7 board (QEMU mps2-an500): boot it, upload a LUT and
# a table of every form over the UART with wdrctl (unix-socket transport), capture replayed
# frames, and check every pixel against the host build's kernel (target_data check).
# usage: target_test.sh QEMU IMAGE WDRCTL TARGET_DATA WORKDIR
set -eu
qemu=$1 image=$2 wdrctl=$3 data=$4 dir=$5
W=32 H=24 FRAMES=4
rm -rf "$dir" && mkdir -p "$dir"
t0=$(date +%s.%N)
"$data" frames "$dir/frames.bin" $W $H $FRAMES
"$data" lut "$dir/lut.bin"
for form in moebius poly basis compact; do "$data" cal $form "$dir/$form.bin" $W $H; done

"$qemu" -M mps2-an500 -nographic -monitor none -serial "unix:$dir/uart.sock,server=on,wait=off" \
    -kernel "$image" -device "loader,file=$dir/frames.bin,addr=0x60800000,force-raw=on" &
qpid=$!
trap 'kill $qpid 2>/dev/null || true' EXIT
i=0
while [ ! -S "$dir/uart.sock" ]; do i=$((i + 1)); [ $i -lt 100 ] || { echo "QEMU did not start"; exit 1; }; sleep 0.1; done

export WDR_DEVICE="unix:$dir/uart.sock"
# The emulated UART moves some 10-20 KB/s and CI machines are shared: long timeouts, and wait
# for QEMU's socket to listen. Instruction counts are bench_target's; time is never asserted.
ctl() { "$wdrctl" "$@" --timeout 20000 --wait 10000; }
ctl info
ctl lut upload "$dir/lut.bin"
ctl capture -o "$dir/none-1.pfm" 2>/dev/null
ctl capture -o "$dir/none-2.pfm" 2>/dev/null
rc=0
"$data" check "$dir/frames.bin" none "$dir/none-1.pfm" "$dir/none-2.pfm" || rc=1
for form in moebius poly basis compact; do
    ctl cal upload "$dir/$form.bin"
    ctl capture -o "$dir/$form-1.pfm" 2>/dev/null
    ctl capture -o "$dir/$form-2.pfm" 2>/dev/null
    "$data" check "$dir/frames.bin" "$dir/$form.bin" "$dir/$form-1.pfm" "$dir/$form-2.pfm" || rc=1
done
t1=$(date +%s.%N)
echo "target test: 10 frames of ${W}x${H} ($((10 * W * H)) pixels) compared, 5 forms, $(awk "BEGIN { printf \"%.1f\", $t1 - $t0 }") s"
exit $rc
