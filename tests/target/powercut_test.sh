#!/bin/sh
# Real power cuts on the emulated mps2-an500: QEMU killed with SIGKILL while the board works,
# its file-backed PSRAM keeping what a flash would; then a power-on, and the board must run v1
# or v2, never neither (nor an image nobody signed). 32 cuts, spread over
#   upload   (13): `wdrctl fw upload v2` from the factory state (v1 running), cut at 1/14 .. 13/14
#                  of the upload's measured time;
#   boot     (10): power-on with v2 pending: cut every 30 ms from QEMU's start, over the bootloader's
#                  ATTEMPT record, its copy and the first instructions of v2;
#   confirm   (9): v2 on its test boot: `wdrctl fw confirm; wdrctl reboot`, cut at 1/10 .. 9/10 of
#                  the sequence's measured time (CONFIRMED, the floor raise, the reset, the
#                  bootloader rejecting v1 under the new floor).
# (50 cuts until 2026-12-05, 170 s: CI's longest test; every flash write's cut is the host-side
# powerloss runners' job, these check that real SIGKILLs land where the runners say.)
# Each cut starts from a snapshot of the PSRAM file taken at a quiet moment. Prints a table of
# the cut points and what ran after each; fails on any board that answers nothing.
# usage: powercut_test.sh QEMU BOOT_ELF FACTORY_HEX WDRCTL TARGET_DATA DEV_KEY APP_BIN WORKDIR
set -eu
qemu=$1 boot=$2 factory=$3 wdrctl=$4 data=$5 key=$6 app=$7 dir=$8
. "$(dirname "$0")/qemu_board.sh"
rm -rf "$dir" && mkdir -p "$dir"
"$data" frames "$dir/frames.bin" 32 24 1
"$wdrctl" fw sign -k "$key" -o "$dir/v2.img" --version 2.0.0 --security-counter 2 --board mps2-an500 \
    --load-addr 0x00020000 "$app" >/dev/null
board_init "$qemu" "$boot" "$wdrctl" "$dir/frames.bin" "$dir"
trap board_cut EXIT

now_ms() { echo $(($(date +%s%N) / 1000000)); }
snapshot() { board_cut; cp "$board_psram" "$dir/$1.psram"; }
restore() { cp "$dir/$1.psram" "$board_psram"; }
version() { # what the board runs, or "none" when nothing answers
    ctl_quick info 2>/dev/null | sed -n 's/^firmware: *\([0-9][0-9.]*[0-9]\).*/\1/p' | grep . || echo none
}
slot_b() { # state, and its test boots when it has any
    ctl_quick fw status 2>/dev/null | sed -n 's/^slot B: *\([a-z]*\).*attempts \([0-9]*\).*/\1 \2/p; s/^slot B: *\([a-z]*\)$/\1/p' |
        awk '{ print ($2 > 0) ? $1 ", " $2 " test boot(s)" : $1 }'
}

# ---- Snapshots, and the time each sequence takes uninterrupted -------------------------------
board_blank
board_flash "$factory" >/dev/null
[ "$(version)" = 1.0.0 ] || { echo "FAIL: the factory image does not run v1" >&2; exit 1; }
snapshot factory
board_power_on
ctl_up
t0=$(now_ms)
ctl fw upload "$dir/v2.img" >/dev/null
upload_ms=$(($(now_ms) - t0))
snapshot pending
board_power_on
[ "$(version)" = 2.0.0 ] || { echo "FAIL: the pending v2 does not run at power-on" >&2; exit 1; }
snapshot testing
board_power_on
ctl_up
t0=$(now_ms)
ctl fw confirm >/dev/null
ctl_reboot >/dev/null
confirm_ms=$(($(now_ms) - t0))
board_cut
echo "uninterrupted: upload ${upload_ms} ms, confirm + reboot ${confirm_ms} ms"

# ---- The cuts --------------------------------------------------------------------------------------
bad=0 n=0 v1=0 v2=0
printf '%-4s %-8s %9s  %-8s %s\n' cut phase "at (ms)" runs "slot B after the power-on"
cut_at() { # PHASE SNAPSHOT DELAY_MS COMMAND...
    phase=$1 snap=$2 delay=$3
    shift 3
    restore "$snap"
    board_power_on
    if [ $# -gt 0 ]; then
        ctl_up
        ("$@" >/dev/null 2>&1 &)
    fi
    sleep "$(awk "BEGIN { printf \"%.3f\", $delay / 1000 }")"
    board_cut
    board_power_on
    v=$(version)
    b=
    [ "$v" = none ] || b=$(slot_b)
    board_cut
    n=$((n + 1))
    case $v in
    1.0.0) v1=$((v1 + 1)) ;;
    2.0.0) v2=$((v2 + 1)) ;;
    *) bad=$((bad + 1)) v="NONE" ;;
    esac
    printf '%-4d %-8s %9d  %-8s %s\n' "$n" "$phase" "$delay" "$v" "${b:--}"
}
for i in $(seq 1 13); do cut_at upload factory $((upload_ms * i / 14)) ctl fw upload "$dir/v2.img"; done
for i in $(seq 1 10); do cut_at boot pending $((30 * i)); done
confirm_seq() { ctl fw confirm && ctl_reboot; }
for i in $(seq 1 9); do cut_at confirm testing $((confirm_ms * i / 10)) confirm_seq; done
echo "power cuts: $n, after which v1 ran $v1 times, v2 $v2 times, nothing $bad times"
[ "$bad" -eq 0 ]
