#!/bin/busybox sh
# /init of the VM test (busybox sh). One Linux machine plays both sides: the board (wdr-board
# on the FunctionFS gadget, wdrvb.ko for its lines and converters, mtdram for its flash) and
# the host (wdrctl over libusb, through dummy_hcd). Each check prints one line
#   @@RESULT <name> PASS|FAIL <detail>
# which vm_run.sh collects for the CTest tests of tests/vm, and facts about the kernel
#   @@FACT <name> <value>
# which vm_table.sh compares between kernels. The main path runs once per wdr-board build in
# /usr/bin (wdr-board: libgpiod 1.x; wdr-board-gpiod2: libgpiod 2.x), the probes once. The
# gadget is made by the installed script (wdr-gadget), as on a real board. Then it powers off.
/bin/busybox mkdir -p /proc /sys /dev /tmp /sbin /usr/sbin /usr/bin
/bin/busybox --install -s
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
mount -t tmpfs tmp /tmp
export PATH=/usr/bin:/bin:/sbin:/usr/sbin WDR_DEVICE=usb HOME=/tmp
exec >/dev/console 2>&1

G=/sys/kernel/config/usb_gadget/wdrcam
FFS=/dev/ffs-wdrcam
CONFIG=/data/vm-wdrvb.json # boards/vm-wdrvb/wdr-board.json
BOARD=
BIN=wdr-board # the build under test
LUT=/data/test.lut
CAL=/data/test.cal
. /data/params.env # CAL_GAIN, MTD_KIB, MTD_ERASE_KIB, VM_QUICK

result() { echo "@@RESULT $1 $2 $3"; }
fact() { echo "@@FACT $1 $2"; }
log() { echo "== $*"; }
# wdrctl with a bound: a hung board must fail the check, not the whole VM run.
# 10 s past the frame time: TCG-emulated, a loaded 2-core machine took over 3 s for one VGA frame (341 of 480 rows)
ctl() { timeout 60 wdrctl "$@" --timeout 10000; }

load_modules() {
    for ko in $(cat /lib/modules/order); do
        case $ko in
        dummy_hcd.ko) continue ;; # per link speed, see link_up
        wdrvb.ko) continue ;;     # after the first bring-up check
        mtdram.ko) insmod /lib/modules/$ko total_size="$MTD_KIB" erase_size="$MTD_ERASE_KIB" ;;
        *) insmod /lib/modules/$ko ;;
        esac || echo "insmod $ko failed"
    done
    mount -t configfs none /sys/kernel/config
}

# dummy_hcd with the given parameters: the host controller and the device controller in one.
link_up() {
    insmod /lib/modules/dummy_hcd.ko "$@" || echo "insmod dummy_hcd $* failed"
}

host_device() { # the sysfs directory of the board as the host sees it
    for d in /sys/bus/usb/devices/*; do
        [ "$(cat $d/idVendor 2>/dev/null)" = 1209 ] && [ "$(cat $d/idProduct)" = 0001 ] && echo $d && return 0
    done
    return 1
}

host_node_ready() { # libusb opens /dev/bus/usb/BUS/DEV
    d=$(host_device) && test -c "$(printf /dev/bus/usb/%03d/%03d $(cat $d/busnum) $(cat $d/devnum))"
}

uptime_s() { cut -d. -f1 /proc/uptime; }

wait_for() { # seconds, command...: poll until the command succeeds, by the clock (a loaded VM is slow)
    local until=$(($(uptime_s) + $1))
    shift
    while ! "$@" >/dev/null 2>&1; do
        [ $(uptime_s) -lt $until ] || return 1
        sleep 0.1
    done
}

# Start wdr-board, bind the gadget (the kernel unbinds the UDC when the program exits), wait
# until the host has enumerated the board.
board_start() {
    $BIN --config $CONFIG >>/tmp/board.log 2>&1 &
    BOARD=$!
    wdr-gadget bind || { log "wdr-gadget bind failed"; cat /tmp/board.log; return 1; }
    wait_for 10 host_device || { log "the host did not enumerate the board"; dmesg | tail -20; return 1; }
    wait_for 5 host_node_ready
    sleep 0.3
}

board_stop() {
    wdr-gadget unbind
    [ -n "$BOARD" ] && kill $BOARD 2>/dev/null && wait $BOARD 2>/dev/null
    BOARD=
}

# Each probe starts on a fresh wdr-board, so that one probe's damage does not fail the next.
board_restart() { board_stop; board_start; }

board_threads() { sed -n 's/^Threads:[[:space:]]*//p' /proc/$BOARD/status 2>/dev/null; }

field() { sed -n "s/^$1:[[:space:]]*//p"; } # a line of `wdrctl status`

# A capture, checked pixel by pixel against the sensor model (with the calibration if given).
capture_check() { # name, then GAIN when a calibration is active
    local frame=/tmp/$1.pfm out
    shift
    out=$(ctl capture -o $frame 2>&1) || { rc=$?; echo "$out"; return $rc; }
    vm_board_model check $LUT $frame "$@"
}

model_count() { awk -v k=$1 '$1 == k { print $2 }' /sys/devices/platform/wdrvb/counters; }
frames_started_since() { [ $(model_count resets) -ge $(($1 + 2)) ]; }

counters_zero() { # the model's protocol errors, all zero; the last line sums them up
    local c=/sys/devices/platform/wdrvb/counters bad
    sed 's/^/counter /' $c
    bad=$(awk '$1 ~ /^(reads_without|converts_without|dac_out|bad_|steps_over)/ && $2 != 0 { printf "%s=%s ", $1, $2 }' $c)
    echo "model: $(awk '{ printf "%s=%s ", $1, $2 }' $c | sed 's/ $//'); protocol errors: ${bad:-none}"
    [ -z "$bad" ]
}

run() { # name, command...: one check (not in a subshell: it may restart the board)
    local name=$1 t0 verdict
    shift
    log "$name"
    t0=$(cut -d' ' -f1 /proc/uptime)
    if "$@" >/tmp/check.log 2>&1; then verdict=PASS; else verdict=FAIL; fi
    sed 's/^/  | /' /tmp/check.log
    cat /tmp/check.log >>/tmp/all-checks.log
    result "$name" $verdict "$(tail -1 /tmp/check.log) [$(awk -v a=$t0 '{printf "%.1f s", $1 - a}' /proc/uptime)]"
}

# ---- Checks ---------------------------------------------------------------------------------

bringup_names() { # config device: wdr-board must fail naming the device and errno
    local out
    out=$(timeout 10 wdr-board --config $1 2>&1)
    echo "$out"
    echo "$out" | grep -q "$2" && echo "$out" | grep -qi 'no such file'
}

self_test() { # the build's self-test must pass and say so
    local out rc
    out=$(timeout 30 $BIN --config $CONFIG --self-test 2>&1); rc=$?
    echo "$out"
    [ $rc = 0 ] && echo "$out" | grep -q '^self-test: PASS'
}

self_test_unbound() { # wdrvb.ko unbound_line=N: exit 1 naming line $2 at offset $1
    local out rc
    out=$(timeout 30 $BIN --config $CONFIG --self-test 2>&1); rc=$?
    echo "$out"
    echo "exit $rc"
    [ $rc = 1 ] && echo "$out" | grep -q "^FAIL line $2 (/dev/gpiochip[0-9]* offset $1): driven 1, reads 0"
}

# SIGTERM during a stream: wdr-board exits 0 and says so, the kernel unbinds the gadget, the
# host's stream ends (no hang), and after a restart both tables are intact and a capture checks.
check_sigterm() {
    local resets0 pid rc lut cal
    lut=$(vm_board_model crc $LUT) cal=$(vm_board_model crc $CAL)
    resets0=$(model_count resets)
    wdrctl stream --timeout 5000 >/tmp/stream.log 2>&1 &
    pid=$!
    wait_for 30 frames_started_since $resets0
    kill -TERM $BOARD
    wait $BOARD; rc=$?
    BOARD=
    echo "wdr-board exit status after SIGTERM mid-stream: $rc"
    tail -1 /tmp/board.log
    wait_for 10 sh -c "test -z \"\$(cat $G/UDC)\"" || { echo "UDC still bound: $(cat $G/UDC)"; return 1; }
    wait $pid; echo "host stream ended: exit $?"
    [ $rc = 0 ] && tail -1 /tmp/board.log | grep -q 'stopped on signal 15' || return 1
    board_start || return 1
    status=$(ctl status)
    echo "$status" | grep -q "crc $lut" && echo "$status" | grep -q "crc $cal" || { echo "$status"; echo "tables lost (want $lut, $cal)"; return 1; }
    echo "after the restart: LUT crc $lut and calibration crc $cal intact"
    capture_check sigterm $CAL_GAIN
}

# What wdr-board.service does, in a loop: start wdr-board, bind the gadget, restart it when it
# exits with 75 (hal_reset: a REBOOT request).
supervise() {
    local rc
    while :; do
        $BIN --config $CONFIG >>/tmp/board.log 2>&1 &
        echo $! >/tmp/board.pid
        wdr-gadget bind >/dev/null 2>&1
        wait $(cat /tmp/board.pid); rc=$?
        echo "supervisor: $BIN exited with $rc" >>/tmp/board.log
        [ $rc = 75 ] || return 0
    done
}

# REBOOT over USB: wdr-board answers, exits 75 (ramp stopped, endpoints closed), the supervisor
# starts it again and the host finds the board from a new start.
check_reboot() {
    local out pid0
    board_stop
    supervise &
    wait_for 15 host_device || { echo "the supervised board never enumerated"; return 1; }
    wait_for 5 host_node_ready
    sleep 0.3
    pid0=$(cat /tmp/board.pid)
    out=$(timeout 60 wdrctl reboot --timeout 3000 2>&1); rc=$?
    echo "$out"
    grep 'supervisor:' /tmp/board.log | tail -1
    [ $rc = 0 ] && grep -q "supervisor: $BIN exited with 75" /tmp/board.log && [ "$(cat /tmp/board.pid)" != "$pid0" ] ||
        { echo "wdrctl reboot: exit $rc"; kill $(cat /tmp/board.pid); return 1; }
    ctl info >/dev/null || { echo "no answer after the reboot"; return 1; }
    echo "rebooted: pid $pid0 exited with 75, pid $(cat /tmp/board.pid) answers"
    wdr-gadget unbind
    kill $(cat /tmp/board.pid) && wait
}

gadget_no_udc() { # the script refuses to bind without a UDC, naming where it looked
    local out rc
    mkdir -p /tmp/no-udc
    out=$(WDR_UDC_CLASS=/tmp/no-udc wdr-gadget bind 2>&1); rc=$?
    echo "$out"; echo "exit $rc"
    [ $rc = 69 ] && echo "$out" | grep -q 'no USB device controller in /tmp/no-udc'
}

gadget_up() {
    wdr-gadget up || return 1
    echo "idVendor $(cat $G/idVendor) idProduct $(cat $G/idProduct) product $(cat $G/strings/0x409/product)"
    [ "$(cat $G/idVendor)" = 0x1209 ] && [ "$(cat $G/idProduct)" = 0x0001 ] && grep -q " $FFS functionfs " /proc/mounts
}

gadget_down() {
    board_stop
    wdr-gadget down || return 1
    wdr-gadget status
    [ ! -d $G ] && ! grep -q " $FFS functionfs " /proc/mounts
}

# In the asan build the programs carry ASan and UBSan: any report they printed fails this.
check_sanitizers() {
    if grep -E 'AddressSanitizer|LeakSanitizer|runtime error:' /tmp/board.log /tmp/all-checks.log; then return 1; fi
    echo "no sanitizer report from wdr-board or the host programs"
}

check_info() { out=$(ctl info) && echo "$out" && echo "$out" | grep -q wdrcam-linux; }
check_status() { ctl status; }

upload_survives_restart() { # kind file field
    local want line
    ctl $1 upload $2 || return 1
    want=$(vm_board_model crc $2)
    board_stop; board_start || return 1
    line=$(ctl status | field "$3")
    echo "after restart: $3 $line, file crc $want"
    echo "$line" | grep -q "crc $want"
}

check_stream() {
    out=$(ctl stream -n 2 2>&1) || { echo "$out"; return 1; }
    echo "$out"
    echo "$out" | grep -q '2 frames'
}

probe_autosuspend() {
    board_restart || return 1
    d=$(host_device) || return 1
    echo 300 >$d/power/autosuspend_delay_ms
    echo auto >$d/power/control
    wait_for 15 grep -q '^suspended' $d/power/runtime_status
    echo "runtime status after 300 ms idle: $(cat $d/power/runtime_status)"
    grep -q '^suspended' $d/power/runtime_status || { echo on >$d/power/control; echo "the host never suspended the board"; return 1; }
    ctl info >/dev/null; rc=$?
    echo on >$d/power/control
    [ $rc = 0 ] && echo "info after autosuspend: ok" || echo "info after autosuspend: exit $rc"
    return $rc
}

probe_control() {
    board_restart || return 1
    before=$(board_threads)
    vm_usbprobe control; rc=$?
    sleep 0.5
    after=$(board_threads)
    echo "board threads: $before before, $after after"
    ctl info >/dev/null || { echo "info after the control requests failed"; return 1; }
    [ $rc = 0 ] && [ "$before" = "$after" ]
}

probe_bus_reset() {
    board_restart || return 1
    vm_usbprobe reset || return 1
    wait_for 10 host_device && sleep 0.5
    ctl info >/dev/null || { echo "info after the bus reset failed"; return 1; }
    capture_check reset $CAL_GAIN
}

probe_killed_host() {
    board_restart || return 1
    local resets0 pid
    resets0=$(model_count resets)
    wdrctl stream --timeout 20000 >/tmp/stream.log 2>&1 &
    pid=$!
    wait_for 30 frames_started_since $resets0 # the second frame began: the stream runs
    kill -9 $pid
    wait $pid 2>/dev/null
    echo "streaming host killed after $(($(model_count resets) - resets0)) frame starts"
    [ $(model_count resets) -ge $((resets0 + 2)) ] || { cat /tmp/stream.log; echo "the stream never ran"; return 1; }
    capture_check killed $CAL_GAIN
    rc=$?
    [ $rc = 0 ] || echo "capture after a killed host: exit $rc"
    return $rc
}

probe_link() { # speed, dummy_hcd parameters...
    local want=$1 got
    shift
    board_stop
    rmmod dummy_hcd
    link_up "$@"
    board_start || return 1
    got=$(vm_usbprobe speed)
    echo "link: $got speed"
    [ "$got" = "$want" ] || return 1
    ctl info >/dev/null || { echo "info over a $want-speed link failed"; return 1; }
    capture_check $want $CAL_GAIN
}

flash_fresh() { # mtdram comes up erased
    rmmod mtdram && insmod /lib/modules/mtdram.ko total_size="$MTD_KIB" erase_size="$MTD_ERASE_KIB" ||
        echo "mtdram reload failed"
}

# ---- The run --------------------------------------------------------------------------------

# The main path of one wdr-board build: self-test, tables that survive a restart, captures
# checked pixel by pixel, a stream, SIGTERM, the model's counters.
main_path() { # prefix
    local p=$1
    run ${p}_self_test self_test
    if ! board_start; then
        result ${p}_board_start FAIL "$BIN did not come up"
        return 1
    fi
    result ${p}_board_start PASS "$BIN enumerated on $(vm_usbprobe speed) speed"
    run ${p}_info check_info
    run ${p}_status check_status
    run ${p}_lut_survives_restart upload_survives_restart lut $LUT LUT
    run ${p}_capture_pixels capture_check raw
    [ -n "$VM_QUICK" ] && return 0
    run ${p}_stream check_stream
    # tests/vm/v4l2: wdrctl stream --v4l2 read by v4l2-ctl, once per kernel (the libgpiod 1.x build)
    [ $p = gpiod1 ] && [ -f /v4l2/checks.sh ] && . /v4l2/checks.sh
    run ${p}_cal_survives_restart upload_survives_restart cal $CAL calibration
    run ${p}_capture_calibrated capture_check calibrated $CAL_GAIN
    run ${p}_sigterm check_sigterm
    run ${p}_model_counters counters_zero
}

t_init=$(cut -d' ' -f1 /proc/uptime)
log "kernel $(uname -r), $(nproc) CPU, init at $t_init s"
fact kernel "$(uname -r)"
fact init_at_s "$t_init"
load_modules
link_up
fact udc "$(ls /sys/class/udc | tr '\n' ' ')"
run gadget_up gadget_up
run gadget_no_udc gadget_no_udc
run bringup_message_spi bringup_names $CONFIG /dev/spidev0.0 # no virtual board yet
insmod /lib/modules/wdrvb.ko
fact gpio_devices "$(ls /sys/bus/gpio/devices | tr '\n' ' ')"
fact mtd "$(tr '\n' ';' </proc/mtd)"
sed 's/"mtd": "[^"]*"/"mtd": "wdr-tables"/' $CONFIG >/tmp/wrong-mtd.json
run bringup_message_mtd bringup_names /tmp/wrong-mtd.json "MTD partition 'wdr-tables' (no such partition in /proc/mtd)"

for build in gpiod1:wdr-board gpiod2:wdr-board-gpiod2; do
    BIN=${build#*:}
    if ! command -v $BIN >/dev/null; then
        result ${build%%:*}_self_test SKIP "$BIN not in this initramfs (see vm_run.sh: libgpiod 2.x build skipped)"
        continue
    fi
    fact ${build%%:*}_board "$($BIN --config $CONFIG --self-test 2>&1 | head -1)"
    flash_fresh # each build starts from an erased flash: the same checks, the same answers
    main_path ${build%%:*}
    board_stop
done
BIN=wdr-board

if [ -z "$VM_QUICK" ] && board_start; then
    run probe_autosuspend probe_autosuspend
    run probe_control_requests probe_control
    run probe_bus_reset probe_bus_reset
    run probe_killed_host probe_killed_host
    run probe_superspeed probe_link super is_super_speed=1
    run probe_fullspeed probe_link full is_high_speed=0
    run model_counters_end counters_zero
    run reboot check_reboot
    board_stop
fi

# One line left unconnected (row address bit 3, offset 19): each build's self-test must name it.
rmmod wdrvb
insmod /lib/modules/wdrvb.ko unbound_line=19
for build in gpiod1:wdr-board gpiod2:wdr-board-gpiod2; do
    BIN=${build#*:}
    command -v $BIN >/dev/null || continue
    run ${build%%:*}_self_test_unbound self_test_unbound 19 'row_address\[3\]'
done
BIN=wdr-board
rmmod wdrvb
insmod /lib/modules/wdrvb.ko

run gadget_down gadget_down
run sanitizer_reports check_sanitizers
fact dmesg_warnings "$(dmesg | grep -c -E 'WARNING|BUG:|Call Trace') (WARNING, BUG or a call trace)"
fact dmesg_usb "$(dmesg | grep -E 'dummy_hcd|dummy_udc|functionfs|ffs|gadget|usb 1-1|usb 2-1' | sed 's/^\[[^]]*\] //; s/[0-9]\+/N/g' | sort -u | tr '\n' ';' | cut -c1-400)"
fact checks_done_at_s "$(cut -d' ' -f1 /proc/uptime)"
log "board log"
sed 's/^/  board| /' /tmp/board.log
echo "@@DONE"
poweroff -f
