#!/bin/sh
# The firmware image on an emulated Cortex-M7 board (QEMU mps2-an500): flash the factory image
# (bootloader + signed firmware) through GDB, boot it, upload a LUT and a table of every form
# over the UART with wdrctl (unix-socket transport), capture replayed frames, and check every
# pixel against the host build's kernel (target_data check).
# usage: target_test.sh QEMU BOOT_ELF FACTORY_HEX WDRCTL TARGET_DATA WORKDIR
set -eu
qemu=$1 boot=$2 factory=$3 wdrctl=$4 data=$5 dir=$6
. "$(dirname "$0")/qemu_board.sh"
W=32 H=24 FRAMES=4
rm -rf "$dir" && mkdir -p "$dir"
t0=$(date +%s.%N)
"$data" frames "$dir/frames.bin" $W $H $FRAMES
"$data" lut "$dir/lut.bin"
for form in moebius poly basis compact; do "$data" cal $form "$dir/$form.bin" $W $H; done

board_init "$qemu" "$boot" "$wdrctl" "$dir/frames.bin" "$dir"
trap board_cut EXIT
board_blank
board_flash "$factory"

# The emulated UART moves some 10-20 KB/s and CI machines are shared: long timeouts (ctl), and
# wait for QEMU's socket to listen. Instruction counts are bench_target's; time is never asserted.
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
