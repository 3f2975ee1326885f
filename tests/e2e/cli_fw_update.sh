#!/bin/sh
# usage: cli_fw_update.sh WDRCTL WDR_SIMBOARD SOURCE_DIR WORKDIR
# The field update as a user types it, through the wdrctl program and wdr-simboard (its resets go
# through the bootloader's logic compiled for the host): a factory v1 (--firmware), `fw upload` v2,
# `reboot`: `info` says v2, test boot; `fw confirm`, `reboot`: still v2. Before that, on v1: a
# flipped byte, another key, a downgrade, another board's image and a truncated one, each refused
# by the board (--no-verify: the board's own checks, not wdrctl's) with its reason and the
# sentence "nothing is pending, v1... still runs", and v1 still answering; wdrctl's own checks
# refuse the flipped, truncated and other-board files before sending them. Prints the upload
# figures (bytes, time, UART estimates) and one `fw status`.
set -u
ctl=$1 simboard=$2 src=$3 d=$4
board=sim-qvga
dev=$src/firmware/boot/keys/dev-signing-key.NOT-FOR-PRODUCTION.pem
rm -rf "$d" && mkdir -p "$d" && cd "$d" || exit 1
pid=
trap '[ -n "$pid" ] && kill "$pid" 2>/dev/null; wait 2>/dev/null' EXIT
export WDR_DEVICE="sim:$d/b.sock" CI=1

fail() { echo "FAIL: $*"; [ -f simboard.log ] && tail -20 simboard.log; exit 1; }
# expect EXIT REGEX CMD...: the exit code and a line of the output
expect() {
    want=$1; regex=$2; shift 2
    out=$("$@" 2>&1); rc=$?
    printf '%s\n' "$out"
    [ "$rc" -eq "$want" ] || fail "exit $rc, expected $want: $*"
    printf '%s\n' "$out" | grep -q -- "$regex" || fail "output lacks /$regex/: $*"
}
sign() { # sign OUT VERSION COUNTER [KEY [BOARD]]
    "$ctl" fw sign --key "${4:-$dev}" app.bin -o "$1" --version "$2" --security-counter "$3" --board "${5:-$board}" \
        > /dev/null || fail "fw sign $1"
}
v1_answers() { expect 0 "firmware:      1.0.0+1, slot A" "$ctl" info; }

# ---- images ----
head -c 262144 /dev/urandom > app.bin
openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out other.pem 2>/dev/null || fail "genpkey"
sign v1.img 1.0.0+1 5
sign v2.img 2.0.0+2 6
sign other-key.img 2.0.0+2 6 other.pem
sign downgrade.img 2.0.0+2 4
sign other-board.img 2.0.0+2 6 "$dev" mps2-an500
sign v3.img 3.0.0+3 7
cp v2.img flipped.img && printf '\001' | dd of=flipped.img bs=1 seek=5000 conv=notrunc 2>/dev/null
head -c 200000 v2.img > truncated.img

# ---- a blank board flashed with v1 ----
"$simboard" --board "$src/boards/$board/board.json" --scene "$src/sim/scenes/window.json" --socket "$d/b.sock" \
    --flash "$d/flash.bin" --firmware v1.img > simboard.log 2>&1 &
pid=$!
expect 0 "firmware:      1.0.0+1, slot A" "$ctl" --wait 20000 info

# ---- refusals on v1: the board's reasons, v1 still answering ----
still="nothing is pending, v1.0.0+1 in slot A still runs"
expect 65 "refused by the board: its SHA-256 differs from its trailer's: the image is damaged (BAD_HASH); $still" \
    "$ctl" fw upload --no-verify flipped.img
v1_answers
expect 65 "refused by the board: signed by a key the board does not trust (BAD_KEY); $still" \
    "$ctl" fw upload other-key.img
v1_answers
expect 65 "refused by the board: its security counter is below the board's floor: a downgrade (DOWNGRADE); $still" \
    "$ctl" fw upload downgrade.img
v1_answers
expect 65 "refused by the board: the image is for another board (BAD_BOARD); $still" \
    "$ctl" fw upload --no-verify other-board.img
v1_answers
expect 65 "truncated.img: refused by the board: .*; $still" "$ctl" fw upload --no-verify truncated.img
v1_answers
# wdrctl's own checks, before any byte goes out
expect 65 "flipped.img: trailer field sha256: .*the image is damaged" "$ctl" fw upload flipped.img
expect 65 "truncated.img: 200000 bytes, but header field image_size says 262344" "$ctl" fw upload truncated.img
expect 65 "other-board.img: header field board: 'mps2-an500', but the board is '$board' (nothing sent)" \
    "$ctl" fw upload other-board.img
expect 0 "slot B:           incomplete\|slot B:           empty" "$ctl" fw status # nothing pending after all that

# ---- the update ----
expect 0 "v2.img: v2.0.0+2 stored in slot B, pending" "$ctl" fw upload v2.img
printf '%s\n' "$out" | grep -q "at 115200 baud" || fail "no UART estimate"
echo "figures: $(printf '%s\n' "$out" | tail -2 | tr '\n' ' ')"
expect 0 "slot B:           pending    v2.0.0+2" "$ctl" fw status
expect 0 "was v1.0.0+1 in slot A, now v2.0.0+2 in slot B (test boot)" "$ctl" reboot
expect 0 "firmware:      2.0.0+2, slot B, test boot" "$ctl" info
expect 0 "slot B:           testing    v2.0.0+2" "$ctl" fw status
expect 65 "v3.img: refused by the board: the running image is a test boot: confirm it (wdrctl fw confirm)" \
    "$ctl" fw upload v3.img
expect 0 "v2.0.0+2 in slot B (test boot): confirmed, it stays" "$ctl" fw confirm
# v1's counter (5) is below the floor v2's confirm raised (6): nothing valid to go back to
expect 65 "fw revert: refused by the board: the other slot holds no valid confirmed image: nothing to revert to" \
    "$ctl" fw revert
expect 0 "now v2.0.0+2 in slot B$" "$ctl" reboot
expect 0 "firmware:      2.0.0+2, slot B$" "$ctl" info
expect 0 "last reset:       software" "$ctl" fw status
printf '%s\n' "$out" | grep -q "slot B:           confirmed  v2.0.0+2" || fail "v2 not confirmed"
printf '%s\n' "$out" | grep -q "security floor:   6" || fail "the floor did not follow v2's counter"
printf '%s\n' "$out" | grep -q "development key: not for production" || fail "the development key is not named"
echo "fw status as a user sees it:"
printf '%s\n' "$out"

# ---- revert: a v2 of the same counter confirmed, then given up: the next boot runs v1 ----
kill "$pid"; wait "$pid" 2>/dev/null
sign same.img 2.0.0+9 5
"$simboard" --board "$src/boards/$board/board.json" --scene "$src/sim/scenes/window.json" --socket "$d/b.sock" \
    --flash "$d/flash2.bin" --firmware v1.img > simboard.log 2>&1 &
pid=$!
expect 0 "firmware:      1.0.0+1, slot A" "$ctl" --wait 20000 info
expect 0 "stored in slot B, pending" "$ctl" fw upload same.img
expect 0 "now v2.0.0+9 in slot B (test boot)" "$ctl" reboot
expect 0 "confirmed, it stays" "$ctl" fw confirm
expect 0 "v2.0.0+9 in slot B: given up: the next boot runs the other slot" "$ctl" fw revert
expect 0 "now v1.0.0+1 in slot A$" "$ctl" reboot
expect 0 "slot B:           rejected   v2.0.0+9 .*(reverted)" "$ctl" fw status
echo "ok: field update through wdrctl"
