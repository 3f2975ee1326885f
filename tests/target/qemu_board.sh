# Sourced by the target tests: one emulated mps2-an500 (QEMU 7.2) whose 16 MiB PSRAM is a file
# (memory-backend-file, share=on: what the table and image flash keep across a power cut,
# SIGKILL included), UART0 on a unix socket for wdrctl, the GDB stub on another.
#   board_init QEMU BOOT_ELF WDRCTL FRAMES DIR   set up (DIR/psram.bin, sockets), nothing runs
#   board_blank                                  a blank board: PSRAM all zero
#   board_flash HEX                              QEMU halted, gdb-multiarch loads HEX through the
#                                                stub (as OpenOCD/pyOCD program a board), reads
#                                                the bootloader back, resets, detaches: it runs
#   board_power_on [QEMU ARGS]                   the bootloader from its flash (see below), PSRAM as left
#   board_cut                                    SIGKILL: a power cut
#   board_gdb GDB ARGS...                        gdb-multiarch commands on the running board
#   ctl ARGS                                     wdrctl on the UART
#   ctl_quick ARGS                               the same, giving up after a few seconds (a board
#                                                that may be down: hung, resetting, bricked)
#   ctl_reboot                                   wdrctl reboot, asking again every 2 s while the
#                                                board restarts (a request sent into the reset is lost)
#   ctl_up                                       wait until a board just powered on answers INFO
# QEMU's SSRAM1, where the bootloader lives at the reset vector, is not a file: a power-on
# reloads it from BOOT_ELF (-kernel), standing for a real M7's internal flash, which keeps it.
board_init() {
    board_qemu=$1 board_boot_elf=$2 board_wdrctl=$3 board_frames=$4 board_dir=$5
    board_psram=$board_dir/psram.bin
    board_pid=
    mkdir -p "$board_dir"
}

board_blank() {
    rm -f "$board_psram"
    truncate -s 16M "$board_psram"
}

board_qemu_start() {
    rm -f "$board_dir/uart.sock" "$board_dir/gdb.sock"
    "$board_qemu" -M mps2-an500,memory-backend=m0 \
        -object "memory-backend-file,id=m0,size=16M,mem-path=$board_psram,share=on" \
        -nographic -monitor none -serial "unix:$board_dir/uart.sock,server=on,wait=off" \
        -gdb "unix:$board_dir/gdb.sock,server=on,wait=off" \
        -device "loader,file=$board_frames,addr=0x60800000,force-raw=on" "$@" &
    board_pid=$!
    i=0
    while [ ! -S "$board_dir/gdb.sock" ]; do
        i=$((i + 1))
        [ $i -lt 200 ] || { echo "QEMU did not start" >&2; return 1; }
        sleep 0.05
    done
}

board_power_on() {
    board_qemu_start -kernel "$board_boot_elf" "$@"
}

board_cut() {
    [ -z "$board_pid" ] && return 0
    kill -KILL "$board_pid" 2>/dev/null || true
    wait "$board_pid" 2>/dev/null || true
    board_pid=
}

board_gdb() {
    gdb-multiarch -q -batch -nx -ex "target remote $board_dir/gdb.sock" "$@" -ex detach >"$board_dir/gdb.log" 2>&1
}

board_flash() {
    board_qemu_start -S || return 1
    boot_bin=${board_boot_elf%.elf}.bin
    board_gdb -ex "load $1" -ex "dump binary memory $board_dir/readback.bin 0 $(wc -c <"$boot_bin")" \
        -ex "monitor system_reset" || { cat "$board_dir/gdb.log" >&2; return 1; }
    cmp -s "$boot_bin" "$board_dir/readback.bin" || { echo "flash: the bootloader read back differs" >&2; return 1; }
    grep -q "Transfer rate" "$board_dir/gdb.log" && sed -n 's/^Transfer rate: /flash: gdb load: /p' "$board_dir/gdb.log"
}

ctl() {
    "$board_wdrctl" "$@" --device "unix:$board_dir/uart.sock" --timeout 20000 --wait 10000
}

ctl_quick() {
    "$board_wdrctl" "$@" --device "unix:$board_dir/uart.sock" --timeout 3000 --retries 1 --wait 5000
}

ctl_reboot() {
    "$board_wdrctl" reboot --device "unix:$board_dir/uart.sock" --timeout 2000 --retries 2 --wait 30000
}

ctl_up() {
    "$board_wdrctl" info --device "unix:$board_dir/uart.sock" --timeout 2000 --retries 5 --wait 10000 >/dev/null
}
