#!/bin/busybox sh
# /init of the VM test (busybox sh). One Linux machine plays both sides: the board (wdr-board
# on the FunctionFS gadget, wdrvb.ko for its lines and converters, mtdram for its flash) and
# the host (wdrctl over libusb, through dummy_hcd). Each check prints one line
#   @@RESULT <name> PASS|FAIL <detail>
# which vm_run.sh collects for the CTest tests of tests/vm. Then the VM powers off.
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
BOARD=
LUT=/data/test.lut
CAL=/data/test.cal
. /data/params.env # CAL_GAIN, MTD_KIB, MTD_ERASE_KIB

result() { echo "@@RESULT $1 $2 $3"; }
log() { echo "== $*"; }
# wdrctl with a bound: a hung board must fail the check, not the whole VM run.
ctl() { timeout 60 wdrctl "$@" --timeout 3000; }

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

gadget_create() {
    mkdir -p $G && cd $G || return 1
    echo 0x1209 >idVendor
    echo 0x0001 >idProduct
    mkdir -p strings/0x409 configs/c.1 functions/ffs.wdrcam
    echo wdrcam >strings/0x409/product
    echo vm-0001 >strings/0x409/serialnumber
    ln -s functions/ffs.wdrcam configs/c.1/
    cd /
    mkdir -p $FFS
    mount -t functionfs wdrcam $FFS
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
    wdr-board >>/tmp/board.log 2>&1 &
    BOARD=$!
    wait_for 10 test -e $FFS/ep1 || { log "wdr-board wrote no descriptors"; cat /tmp/board.log; return 1; }
    ls /sys/class/udc >$G/UDC || return 1
    wait_for 10 host_device || { log "the host did not enumerate the board"; dmesg | tail -20; return 1; }
    wait_for 5 host_node_ready
    sleep 0.3
}

board_stop() {
    echo "" >$G/UDC 2>/dev/null
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

bringup_names() { # device: wdr-board must fail naming it and errno
    local out
    out=$(timeout 10 wdr-board 2>&1)
    echo "$out"
    echo "$out" | grep -q "$1" && echo "$out" | grep -qi 'no such file'
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

# ---- The run --------------------------------------------------------------------------------

log "kernel $(uname -r), $(nproc) CPU, init at $(cut -d' ' -f1 /proc/uptime) s"
load_modules
link_up
gadget_create
run bringup_message_spi bringup_names /dev/spidev0.0 # no virtual board yet
insmod /lib/modules/wdrvb.ko
run bringup_message bringup_names /dev/mtd2 # every device but the table flash
ln -sf mtd0 /dev/mtd2 # hal_linux_config.h wants the table partition at mtd2; mtdram is mtd0
if ! board_start; then
    result board_start FAIL "wdr-board did not come up"
else
    result board_start PASS "wdr-board enumerated on $(vm_usbprobe speed) speed"
    run info check_info
    run status check_status
    run lut_survives_restart upload_survives_restart lut $LUT LUT
    run capture_pixels capture_check raw
    run stream check_stream
    [ -f /v4l2/checks.sh ] && . /v4l2/checks.sh # tests/vm/v4l2: wdrctl stream --v4l2 read by v4l2-ctl
    run cal_survives_restart upload_survives_restart cal $CAL calibration
    run capture_calibrated capture_check calibrated $CAL_GAIN
    run model_counters counters_zero
    run probe_autosuspend probe_autosuspend
    run probe_control_requests probe_control
    run probe_bus_reset probe_bus_reset
    run probe_killed_host probe_killed_host
    run probe_superspeed probe_link super is_super_speed=1
    run probe_fullspeed probe_link full is_high_speed=0
    run model_counters_end counters_zero
fi
run sanitizer_reports check_sanitizers
log "board log"
sed 's/^/  board| /' /tmp/board.log
echo "@@DONE"
board_stop
poweroff -f
