#!/bin/sh
# Field update on the emulated mps2-an500, through the bootloader and over UART0 (wdrctl, unix:
# transport): flash the factory image (bootloader + v1) through GDB; the board's refusals (one
# flipped byte, another key, a downgrade, another board, a truncated image), each with its
# reason, v1 still answering; an unconfirmed v2 reverting to v1 after its 3 test boots; v2
# uploaded, rebooted into, confirmed, kept; a fault planted with GDB (a jump to an invalid
# address) coming back through the watchdog, named by fw status; then a hang (the firmware sent
# into a loop that feeds nothing) caught by the watchdog's early warning.
# usage: fw_update_test.sh QEMU BOOT_ELF FACTORY_HEX APP_ELF WDRCTL TARGET_DATA DEV_KEY WORKDIR
set -eu
qemu=$1 boot=$2 factory=$3 app_elf=$4 wdrctl=$5 data=$6 key=$7 dir=$8
app=${app_elf%.elf}.bin
. "$(dirname "$0")/qemu_board.sh"
rm -rf "$dir" && mkdir -p "$dir"
fail() { echo "FAIL: $*" >&2; exit 1; }

# ---- Images: v2, and one for each refusal -----------------------------------------------------
sign() { # KEY OUT VERSION COUNTER [BOARD]
    "$wdrctl" fw sign -k "$1" -o "$dir/$2" --version "$3" --security-counter "$4" --board "${5:-mps2-an500}" \
        --load-addr 0x00020000 "$app" >/dev/null
}
openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$dir/other-key.pem" 2>/dev/null
sign "$key" v2.img 2.0.0 2
sign "$dir/other-key.pem" other-key.img 2.0.0 2
sign "$key" downgrade.img 0.9.0 0 # the factory image set the floor to 1
sign "$key" other-board.img 2.0.0 2 sim-vga
cp "$dir/v2.img" "$dir/flipped.img"
printf '\125' | dd of="$dir/flipped.img" bs=1 seek=5000 conv=notrunc status=none # one application byte
head -c 30000 "$dir/v2.img" >"$dir/truncated.img"
"$data" frames "$dir/frames.bin" 32 24 1

board_init "$qemu" "$boot" "$wdrctl" "$dir/frames.bin" "$dir"
trap board_cut EXIT
board_blank
board_flash "$factory"

running() { ctl info | sed -n 's/^firmware: *\([0-9][0-9.]*[0-9]\).*/\1/p'; }
expect_running() { # VERSION WHEN
    v=$(running)
    [ "$v" = "$1" ] || fail "$2: the board runs '$v', not $1"
    echo "ok: $2: v$v answers"
}
expect_running 1.0.0 "factory image, flashed through GDB"

# ---- Refusals: the board's own (--no-verify sends the file unchecked) --------------------------
for case in flipped:BAD_HASH other-key:BAD_KEY downgrade:DOWNGRADE other-board:BAD_BOARD truncated:BAD_IMAGE; do
    img=${case%%:*} reason=${case#*:}
    if ctl fw upload --no-verify "$dir/$img.img" >"$dir/out" 2>&1; then
        cat "$dir/out"
        fail "$img.img was accepted"
    fi
    grep -q "($reason)" "$dir/out" || { cat "$dir/out"; fail "$img.img: refused, but not for $reason"; }
    echo "refused: $(cat "$dir/out")"
    expect_running 1.0.0 "after $img.img"
done
ctl fw status | grep -q "slot B: *empty" || ctl fw status | grep -q "slot B: *incomplete" ||
    fail "a refused image left slot B neither empty nor incomplete"

# ---- An unconfirmed v2: 3 test boots, then back to v1 -------------------------------------------
ctl fw upload "$dir/v2.img"
for boot in 1 2 3; do
    ctl_reboot >/dev/null
    expect_running 2.0.0 "test boot $boot of the unconfirmed v2"
done
ctl_reboot >/dev/null
expect_running 1.0.0 "a fourth reset without a confirmation (v2 reverted)"
ctl fw status | grep -q "slot B: *rejected" || { ctl fw status; fail "slot B is not rejected after its 3 test boots"; }

# ---- v2 again: reboot, confirm, reboot: still v2 --------------------------------------------------
ctl fw upload "$dir/v2.img"
ctl_reboot
expect_running 2.0.0 "reboot after the upload (test boot)"
ctl fw confirm
ctl_reboot
expect_running 2.0.0 "reboot after the confirmation"

# ---- A planted fault: the running v2 jumps to an invalid address --------------------------------
# Wait until fw status names the last reset's cause (the watchdog resets 4 s after the last feed).
wait_reset() { # CAUSE WHAT
    i=0
    until ctl_quick fw status >"$dir/status" 2>/dev/null && grep -q "last reset: *$1" "$dir/status"; do
        i=$((i + 1))
        [ $i -lt 8 ] || { cat "$dir/status"; fail "no reset through the watchdog after $2"; }
        sleep 1
    done
}
board_gdb -ex 'set $pc = 0x30000001' || { cat "$dir/gdb.log"; fail "gdb could not plant the fault"; }
wait_reset fault "the fault"
grep -q "0x30000000" "$dir/status" || { cat "$dir/status"; fail "fw status does not name the faulting PC 0x30000000"; }
expect_running 2.0.0 "after the fault and the watchdog's reset"
echo "fw status after the planted fault:"
cat "$dir/status"

# ---- A planted hang: the firmware parked in a loop that never feeds the watchdog ---------------
board_gdb -ex "file $app_elf" -ex 'set $pc = wdr_default_handler' || { cat "$dir/gdb.log"; fail "gdb could not plant the hang"; }
wait_reset watchdog "the hang"
expect_running 2.0.0 "after the hang and the watchdog's reset"
grep "last reset" "$dir/status"
