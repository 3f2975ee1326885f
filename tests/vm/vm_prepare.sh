#!/usr/bin/env bash
# The VM test's kernel side, cached in the build folder: Debian's current linux-image-amd64
# kernel and the modules the test loads, and wdrvb.ko built against the matching headers.
#   vm_prepare.sh CACHE_DIR SOURCE_DIR
# On success prints the kernel ABI and leaves CACHE_DIR/<abi>/{vmlinuz,modules/,modules.order}.
# Exit 77 (CTest skip) with the reason when this machine cannot provide them.
set -euo pipefail
cache=$1 src=$2
skip() { echo "SKIP: $*" >&2; exit 77; }
need() { command -v "$1" >/dev/null || skip "$1 not found (Debian package $2)"; }
need apt-cache apt
need apt-get apt
need dpkg-deb dpkg
need modprobe kmod
need depmod kmod
need make make

# The kernel ABI changes with security updates: take it from the metapackage every time.
current_abi() {
    apt-cache depends linux-image-amd64 2>/dev/null | sed -n 's/^ *Depends: linux-image-\([0-9][^ ]*-amd64\)$/\1/p' | head -1
}
abi=$(current_abi)
if [ -z "$abi" ] && [ "$(id -u)" = 0 ]; then # a fresh machine has no package lists yet
    apt-get update -qq >&2 || true
    abi=$(current_abi)
fi
[ -n "$abi" ] || skip "apt-cache knows no linux-image-amd64 (as root: apt-get update)"
dir=$cache/$abi
headers=$dir/root/usr/src/linux-headers-$abi

# Once per ABI (an older ABI's cache is dropped).
fetch_kernel() {
# The headers of that ABI, their common part and the kbuild tools they depend on.
kbuild=$(apt-cache depends "linux-headers-$abi" 2>/dev/null | sed -n 's/^ *Depends: \(linux-kbuild-[^ ]*\)$/\1/p' | head -1)
common=$(apt-cache depends "linux-headers-$abi" 2>/dev/null | sed -n 's/^ *Depends: \(linux-headers-[^ ]*-common[^ ]*\)$/\1/p' | head -1)
[ -n "$kbuild" ] && [ -n "$common" ] || skip "no linux-headers-$abi in the package lists: the module cannot be built for kernel $abi"

rm -rf "$cache" && mkdir -p "$dir/debs" "$dir/root"
echo "vm_prepare: fetching linux-image-$abi linux-headers-$abi $common $kbuild" >&2
(cd "$dir/debs" && apt-get download -q "linux-image-$abi" "linux-headers-$abi" "$common" "$kbuild" >&2) ||
    skip "apt-get download of kernel $abi and its headers failed (no access to a Debian mirror?)"
for deb in "$dir"/debs/*.deb; do
    dpkg-deb -x "$deb" "$dir/root"
done
rm -rf "$dir/debs"
# The per-flavour Makefile includes the common tree by its installed path: point it here.
echo "include $dir/root/usr/src/$common/Makefile" >"$headers/Makefile"
cc=$(sed -n 's/^CC = .*\(gcc-[0-9][0-9]*\)$/\1/p' "$headers/.kernelvariables")
[ -z "$cc" ] || command -v "$cc" >/dev/null || skip "kernel $abi modules are built with $cc, which is not installed"

# Only the modules the test loads, in load order (dependencies first).
depmod -b "$dir/root" "$abi"
mkdir -p "$dir/modules"
: >"$dir/modules.order"
for m in configfs dummy_hcd libcomposite usb_f_fs mtd mtdram; do
    modprobe --show-depends -d "$dir/root" -S "$abi" "$m" | sed -n 's/^insmod \([^ ]*\).*/\1/p'
done | awk '!seen[$0]++' | while read -r ko; do
    cp "$ko" "$dir/modules/"
    basename "$ko" >>"$dir/modules.order"
done
echo wdrvb.ko >>"$dir/modules.order"
cp "$dir"/root/boot/vmlinuz-"$abi" "$dir/vmlinuz"
# The rest of the image is 400 MB of modules nobody loads here: keep the headers only.
rm -rf "$dir/root/boot" "$dir/root/lib"
touch "$dir/kernel.ready"
}

[ -f "$dir/kernel.ready" ] || fetch_kernel

# The virtual board, built against those headers; its pins come from vboard/vboard_pins.h.
mod=$dir/wdrvb
mkdir -p "$mod"
for f in "$src/tests/vm/vboard/wdrvb.c" "$src/tests/vm/vboard/vboard_model.h" "$src/tests/vm/vboard/vboard_pins.h"; do
    cmp -s "$f" "$mod/${f##*/}" || cp "$f" "$mod/" # unchanged sources keep kbuild incremental
done
[ -f "$mod/Kbuild" ] || echo 'obj-m := wdrvb.o' >"$mod/Kbuild"
make -s -C "$headers" M="$mod" modules >"$dir/wdrvb-build.log" 2>&1 || {
    cat "$dir/wdrvb-build.log" >&2
    echo "vm_prepare: wdrvb.ko does not build against linux-headers-$abi" >&2
    exit 1
}

cp "$mod/wdrvb.ko" "$dir/modules/"
echo "$abi"
