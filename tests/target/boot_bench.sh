#!/bin/sh
# Instructions from reset to the application's first instruction on the mps2-an500, for the
# bootloader and its hash-only twin (no signature check: the measurement's only use). QEMU runs
# with -icount shift=0 (one instruction = 1 ns of virtual time); the bootloader starts CMSDK
# timer 0 (25 MHz: one tick = 40 instructions) at its reset handler's first instruction and
# leaves the time in the boot record's boot_ns; GDB stops the board at the application's reset
# handler (read from the image's vector table) and reads it there. (QEMU's GDB stub cannot
# reach the timers' registers, only memory.)
# Printed, never asserted.
# usage: boot_bench.sh QEMU BOOT_ELF HASHONLY_ELF FACTORY_HEX V1_IMG WDRCTL TARGET_DATA WORKDIR
set -eu
qemu=$1 boot=$2 hashonly=$3 factory=$4 v1=$5 wdrctl=$6 data=$7 dir=$8
. "$(dirname "$0")/qemu_board.sh"
rm -rf "$dir" && mkdir -p "$dir"
frames=$dir/frames.bin
"$data" frames "$frames" 32 24 1
board_init "$qemu" "$boot" "$wdrctl" "$frames" "$dir"
trap board_cut EXIT
board_blank
board_flash "$factory"
ctl info >/dev/null # the first boot raised the floor; the ones measured change nothing
board_cut
entry=$(od -An -tx4 -j68 -N4 "$v1" | tr -d ' ')
entry=$(printf '0x%x' $((0x$entry & ~1)))
app_bytes=$(($(wc -c <"$v1") - 200))

measure() { # ELF -> instructions
    board_init "$qemu" "$1" "$wdrctl" "$frames" "$dir"
    board_qemu_start -kernel "$1" -icount shift=0 -S
    board_gdb -ex "hbreak *$entry" -ex continue -ex "printf \"boot_ns %u\\n\", *(unsigned *)0x203fff18"
    board_cut
    ns=$(sed -n 's/^boot_ns //p' "$dir/gdb.log")
    [ -n "$ns" ] || { cat "$dir/gdb.log" >&2; exit 1; }
    echo "$ns"
}
with=$(measure "$boot")
without=$(measure "$hashonly")
echo "boot time, reset to the application's first instruction (QEMU icount, +-40 instructions; application $app_bytes bytes):"
printf '  %-44s %10d instructions\n' "bootloader (SHA-256 + ECDSA P-256 check)" "$with" \
    "bootloader, hash only (measurement build)" "$without"
printf '  %-44s %10d instructions\n' "the signature check itself" $((with - without))
