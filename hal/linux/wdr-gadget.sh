#!/bin/sh
# wdr-gadget: the wdrcam USB gadget in configfs (libcomposite) and its FunctionFS mount.
#   wdr-gadget up       create the gadget (1209:0001, strings, one FunctionFS function) and mount
#                       FunctionFS; then start wdr-board, which writes the descriptors
#   wdr-gadget bind     wait for wdr-board's endpoints, bind the gadget to the UDC
#   wdr-gadget unbind   unbind it (the host sees the board leave)
#   wdr-gadget down     unbind, unmount, remove the gadget
#   wdr-gadget status   print what exists
# wdr-board.service runs up (ExecStartPre), bind (ExecStartPost) and down (ExecStopPost).
# Environment: WDR_GADGET_NAME (wdrcam), WDR_FFS_DIR (/dev/ffs-NAME), WDR_UDC (a name in
# /sys/class/udc; default: the only or first one), WDR_SERIAL (default: from /etc/machine-id),
# WDR_GADGET_WAIT (seconds bind waits for the endpoints, 10), WDR_CONFIGFS, WDR_UDC_CLASS.
# Exit: 0, 64 usage, 69 no UDC or no endpoints (unavailable), 71 a configfs or mount error.
set -u
NAME=${WDR_GADGET_NAME:-wdrcam}
FFS_DIR=${WDR_FFS_DIR:-/dev/ffs-$NAME}
CONFIGFS=${WDR_CONFIGFS:-/sys/kernel/config}
UDC_CLASS=${WDR_UDC_CLASS:-/sys/class/udc}
G=$CONFIGFS/usb_gadget/$NAME
VID=0x1209 PID=0x0001 # pid.codes test VID:PID, host/lib/transport.h

die() { code=$1; shift; echo "wdr-gadget: $*" >&2; exit "$code"; }
put() { echo "$2" >"$1" 2>/dev/null || die 71 "cannot write '$2' to $1"; }
mounted() { grep -q " $1 $2 " /proc/mounts; }

serial() {
    if [ -n "${WDR_SERIAL:-}" ]; then echo "$WDR_SERIAL"
    elif [ -r /etc/machine-id ]; then cut -c1-16 /etc/machine-id
    else echo 0001
    fi
}

up() {
    modprobe libcomposite 2>/dev/null || true # built in, or loaded already
    [ -d "$CONFIGFS/usb_gadget" ] || mounted "$CONFIGFS" configfs || mount -t configfs none "$CONFIGFS" 2>/dev/null
    [ -d "$CONFIGFS/usb_gadget" ] || die 71 "no $CONFIGFS/usb_gadget: configfs or libcomposite missing"
    mkdir -p "$G" || die 71 "cannot create $G"
    put "$G/idVendor" $VID
    put "$G/idProduct" $PID
    put "$G/bcdDevice" 0x0100
    put "$G/bcdUSB" 0x0200
    mkdir -p "$G/strings/0x409" "$G/configs/c.1/strings/0x409" "$G/functions/ffs.$NAME" || die 71 "cannot populate $G"
    put "$G/strings/0x409/manufacturer" wdrcam
    put "$G/strings/0x409/product" wdrcam
    put "$G/strings/0x409/serialnumber" "$(serial)"
    put "$G/configs/c.1/strings/0x409/configuration" wdrcam
    put "$G/configs/c.1/MaxPower" 250
    [ -e "$G/configs/c.1/ffs.$NAME" ] || ln -s "$G/functions/ffs.$NAME" "$G/configs/c.1/" || die 71 "cannot link the function"
    mkdir -p "$FFS_DIR" || die 71 "cannot create $FFS_DIR"
    mounted "$FFS_DIR" functionfs || mount -t functionfs "$NAME" "$FFS_DIR" || die 71 "cannot mount FunctionFS $NAME on $FFS_DIR"
    echo "wdr-gadget: $G ($VID:$PID) with FunctionFS at $FFS_DIR; start wdr-board, then: wdr-gadget bind"
}

# The UDC: WDR_UDC, else the first in /sys/class/udc (a board has one; dummy_hcd has one).
find_udc() {
    if [ -n "${WDR_UDC:-}" ]; then echo "$WDR_UDC"; return; fi
    for u in "$UDC_CLASS"/*; do
        [ -e "$u" ] && { echo "${u##*/}"; return; }
    done
}

bind() {
    [ -d "$G" ] || die 69 "no gadget $G: run wdr-gadget up first"
    udc=$(find_udc)
    [ -n "$udc" ] || die 69 "no USB device controller in $UDC_CLASS (dwc2 in peripheral mode? dummy_hcd loaded?)"
    [ -e "$UDC_CLASS/$udc" ] || die 69 "no UDC '$udc' in $UDC_CLASS"
    waited=0 # wdr-board opens its endpoints once its descriptors are in ep0
    while [ ! -e "$FFS_DIR/ep1" ]; do
        [ "$waited" -lt $((${WDR_GADGET_WAIT:-10} * 10)) ] || die 69 "no $FFS_DIR/ep1 after ${WDR_GADGET_WAIT:-10} s: is wdr-board running?"
        sleep 0.1
        waited=$((waited + 1))
    done
    [ "$(cat "$G/UDC")" = "$udc" ] || put "$G/UDC" "$udc"
    echo "wdr-gadget: bound to $udc"
}

unbind() {
    [ -e "$G/UDC" ] && [ -n "$(cat "$G/UDC")" ] && put "$G/UDC" ""
    return 0
}

down() {
    [ -d "$G" ] || { echo "wdr-gadget: no gadget $G"; return 0; }
    unbind
    mounted "$FFS_DIR" functionfs && { umount "$FFS_DIR" || die 71 "cannot unmount $FFS_DIR (wdr-board still running?)"; }
    rm -f "$G/configs/c.1/ffs.$NAME"
    rmdir "$G/configs/c.1/strings/0x409" "$G/configs/c.1" "$G/functions/ffs.$NAME" "$G/strings/0x409" "$G" ||
        die 71 "cannot remove $G"
    rmdir "$FFS_DIR" 2>/dev/null || true
    echo "wdr-gadget: $G removed"
}

status() {
    [ -d "$G" ] || { echo "gadget $G: absent"; return 0; }
    echo "gadget $G: $(cat "$G/idVendor"):$(cat "$G/idProduct"), UDC '$(cat "$G/UDC")', FunctionFS $FFS_DIR $(mounted "$FFS_DIR" functionfs && echo mounted || echo 'not mounted')"
}

case ${1:-} in
up | bind | unbind | down | status) "$1" ;;
*) echo "usage: wdr-gadget up|bind|unbind|down|status" >&2; exit 64 ;;
esac
