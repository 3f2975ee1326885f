#!/usr/bin/env bash
# The V4L2 side of the VM test, beside the kernel vm_prepare.sh fetched: Debian's
# v4l2loopback-dkms source built against that kernel's headers (as wdrvb.ko is), and the
# kernel's own videodev module with its dependencies, taken from the same linux-image package.
#   prepare.sh KERNEL_DIR ABI [CACHE_DIR SUITE SOURCE_DIR]
# KERNEL_DIR is vm_prepare.sh's CACHE_DIR/<abi> (its root/usr/src/linux-headers-<abi>). SUITE
# other than bookworm: the packages come through vm_prepare.sh's private sources list in
# CACHE_DIR/apt-SUITE, and the module is built with the compiler wrapper it left (KERNEL_DIR/cc)
# when the kernel's own compiler is missing, as wdrvb.ko is. Leaves
# KERNEL_DIR/v4l2/modules/*.ko and KERNEL_DIR/v4l2/modules.order (load order). Cached: once per ABI.
# Exit 77 with the reason when the machine cannot provide them (the V4L2 checks then say SKIP).
set -euo pipefail
kdir=$1 abi=$2 cache=${3:-} suite=${4:-bookworm} src=${5:-}
out=$kdir/v4l2
headers=$kdir/root/usr/src/linux-headers-$abi
skip() { echo "SKIP: v4l2: $*" >&2; exit 77; }
[ -d "$headers" ] || skip "no headers at $headers"
[ -f "$out/ready" ] && exit 0

rm -rf "$out" && mkdir -p "$out/debs" "$out/root" "$out/modules"
echo "v4l2/prepare: fetching v4l2loopback-dkms and linux-image-$abi (for videodev.ko)" >&2
apt_get() { apt-get "$@"; }
if [ "$suite" != bookworm ]; then
    . "$src/tests/vm/private_apt.sh"
    papt_init "$cache/apt-$suite" "deb http://deb.debian.org/debian $suite main" ||
        skip "apt-get update of $suite failed (no Debian mirror?)"
    apt_get() { papt_get "$@"; }
fi
(cd "$out/debs" && apt_get download -q v4l2loopback-dkms "linux-image-$abi" >&2) ||
    skip "apt-get download v4l2loopback-dkms linux-image-$abi failed (no Debian mirror?)"
for deb in "$out"/debs/*.deb; do
    dpkg-deb -x "$deb" "$out/root"
done
rm -rf "$out/debs"

# videodev and what it needs, in load order, from the kernel's own modules (trixie's are in
# /usr/lib/modules, merged /usr, where depmod -b does not look, and xz-compressed, which busybox
# insmod does not take).
[ -e "$out/root/lib" ] || ln -s usr/lib "$out/root/lib"
depmod -b "$out/root" "$abi"
modprobe --show-depends -d "$out/root" -S "$abi" videodev | sed -n 's/^insmod \([^ ]*\).*/\1/p' |
    while read -r ko; do
        cp "$ko" "$out/modules/"
        case $ko in *.ko.xz) xz -d "$out/modules/${ko##*/}" ;; esac
        name=${ko##*/}
        echo "${name%.ko*}.ko" >>"$out/modules.order"
    done
[ -s "$out/modules.order" ] || skip "kernel $abi has no videodev module"

# v4l2loopback from Debian's DKMS source, against the kernel's headers.
srcdir=$(ls -d "$out"/root/usr/src/v4l2loopback-* 2>/dev/null | head -1)
[ -n "$srcdir" ] || skip "v4l2loopback-dkms holds no source folder"
cc_override=()
[ -x "$kdir/cc" ] && cc_override=("CC=$kdir/cc")
make -s -C "$headers" M="$srcdir" "${cc_override[@]}" modules >"$out/build.log" 2>&1 || {
    cat "$out/build.log" >&2
    echo "v4l2/prepare: v4l2loopback does not build against linux-headers-$abi" >&2
    exit 1
}
cp "$srcdir/v4l2loopback.ko" "$out/modules/"
echo v4l2loopback.ko >>"$out/modules.order"
echo "v4l2/prepare: $(basename "$srcdir") built for $abi; modules: $(tr '\n' ' ' <"$out/modules.order")" >&2
rm -rf "$out/root" # 400 MB of modules nobody loads
touch "$out/ready"
