#!/usr/bin/env bash
# Puts the V4L2 checks into the VM's initramfs: the modules prepare.sh left, v4l2-ctl (Debian
# package v4l-utils) and its libraries, the frame comparer and checks.sh, which vm_init.sh
# sources after its stream check.
#   stage.sh INITRAMFS_ROOT KERNEL_DIR V4L2_COMPARE
# Without the modules or v4l2-ctl it stages a note instead, and checks.sh reports SKIP.
set -euo pipefail
root=$1 kdir=$2 compare=$3
here=$(dirname "$0")
mkdir -p "$root/v4l2"
cp "$here/checks.sh" "$root/v4l2/"
note() { echo "$*" >"$root/v4l2/unavailable"; echo "v4l2/stage: $*" >&2; }
[ -f "$kdir/v4l2/ready" ] || { note "the v4l2loopback module was not built (see tests/vm/v4l2/prepare.sh)"; exit 0; }
ctl=$(command -v v4l2-ctl || true)
[ -n "$ctl" ] || { note "v4l2-ctl not found on the host (Debian package v4l-utils)"; exit 0; }
mkdir -p "$root/lib/modules/v4l2"
cp "$kdir"/v4l2/modules/*.ko "$root/lib/modules/v4l2/"
cp "$kdir/v4l2/modules.order" "$root/lib/modules/v4l2/order"
for b in "$ctl" "$compare"; do
    cp "$b" "$root/usr/bin/"
    ldd "$b" | grep -o '/[^ ]*' | while read -r lib; do
        mkdir -p "$root$(dirname "$lib")"
        cp -L "$lib" "$root$lib"
    done
done
