#!/usr/bin/env bash
# The VM test's kernel side, cached in the build folder: a Debian suite's current
# linux-image-amd64 kernel and the modules the test loads, and wdrvb.ko built against the
# matching headers.
#   vm_prepare.sh CACHE_DIR SOURCE_DIR [SUITE]
# SUITE: bookworm (default: the system's own package lists, Debian 12's 6.1 kernel) or another
# suite through a private sources list (tests/vm/private_apt.sh; trixie: Debian 13's 6.12).
# A newer suite's kernel tools and compiler need a newer system: see kbuild_for_older_host.
# On success prints the kernel ABI and leaves CACHE_DIR/<abi>/{vmlinuz,modules/,modules.order}.
# Exit 77 (CTest skip) with the reason when this machine cannot provide them.
set -euo pipefail
cache=$1 src=$2 suite=${3:-bookworm}
. "$src/tests/vm/private_apt.sh"
apt_get() { apt-get "$@"; }
apt_cache() { apt-cache "$@"; }
host_extra= # packages of the suite that its kernel tools need on this system
if [ "$suite" != bookworm ]; then
    papt_init "$cache/apt-$suite" "deb http://deb.debian.org/debian $suite main" ||
        { echo "SKIP: apt-get update of $suite failed (no Debian mirror?)" >&2; exit 77; }
    apt_get() { papt_get "$@"; }
    apt_cache() { papt_cache "$@"; }
    host_extra=libc6
fi
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
    apt_cache depends linux-image-amd64 2>/dev/null | sed -n 's/^ *Depends: linux-image-\([0-9][^ ]*-amd64\)$/\1/p' | head -1
}
abi=$(current_abi)
if [ -z "$abi" ] && [ "$(id -u)" = 0 ] && [ "$suite" = bookworm ]; then # a fresh machine has no package lists yet
    apt-get update -qq >&2 || true
    abi=$(current_abi)
fi
[ -n "$abi" ] || skip "apt-cache knows no linux-image-amd64 (as root: apt-get update)"
dir=$cache/$abi
headers=$dir/root/usr/src/linux-headers-$abi

# A newer suite's kernel on this system (trixie's 6.12 on Debian 12): its host tools modpost,
# objtool and resolve_btfids need a newer glibc, and its compiler (gcc-14) is not installed.
# The tools run on their own suite's loader and libc (libc6 of that suite, unpacked beside
# them); the module is built by gcc-12 through a wrapper that translates the one gcc-14 option
# the kernel's configuration asks for; BTF for the module is skipped (no pahole). A module
# built so is for the test only: it loads and runs, which is all the VM needs.
kbuild_for_older_host() {
    local want=$1 kbuild_dir
    kbuild_dir=$(ls -d "$dir"/root/usr/lib/linux-kbuild-* | head -1)
    command -v gcc-12 >/dev/null || skip "kernel $abi wants $want; neither it nor gcc-12 is installed"
    local loader=$dir/root/usr/lib64/ld-linux-x86-64.so.2
    local libs=$dir/root/usr/lib/x86_64-linux-gnu:/usr/lib/x86_64-linux-gnu:/lib/x86_64-linux-gnu
    [ -x "$loader" ] || skip "no loader in the $suite libc6 package"
    for b in "$kbuild_dir"/scripts/mod/modpost.real-lsb-64 "$kbuild_dir"/tools/objtool/objtool.real-x86 \
        "$kbuild_dir"/tools/bpf/resolve_btfids/resolve_btfids; do
        [ -f "$b" ] && [ ! -f "$b.bin" ] || continue
        mv "$b" "$b.bin"
        printf '#!/bin/sh\n# built for a newer glibc: run on its own suite'"'"'s loader and libc\nexec %s --library-path %s "$0.bin" "$@"\n' \
            "$loader" "$libs" >"$b"
        chmod +x "$b"
    done
    cat >"$dir/cc" <<'CC'
#!/bin/sh
# gcc-12 in place of the kernel's newer gcc: its one option gcc-12 lacks, translated.
for a; do
    shift
    case $a in -fmin-function-alignment=*) set -- "$@" "-falign-functions=${a#*=}" ;; *) set -- "$@" "$a" ;; esac
done
exec gcc-12 "$@"
CC
    chmod +x "$dir/cc"
    rm -f "$headers/vmlinux" # the BTF base: without pahole, kbuild skips the module's BTF
    echo "vm_prepare: kernel $abi: host tools on $suite's libc, module built with gcc-12 for $want" >&2
}

# Once per ABI (an older ABI's cache is dropped).
fetch_kernel() {
# The headers of that ABI, their common part and the kbuild tools they depend on.
kbuild=$(apt_cache depends "linux-headers-$abi" 2>/dev/null | sed -n 's/^ *Depends: \(linux-kbuild-[^ ]*\)$/\1/p' | head -1)
common=$(apt_cache depends "linux-headers-$abi" 2>/dev/null | sed -n 's/^ *Depends: \(linux-headers-[^ ]*-common[^ ]*\)$/\1/p' | head -1)
[ -n "$kbuild" ] && [ -n "$common" ] || skip "no linux-headers-$abi in the package lists: the module cannot be built for kernel $abi"

rm -rf "$cache"/[0-9]* && mkdir -p "$dir/debs" "$dir/root"
echo "vm_prepare: fetching linux-image-$abi linux-headers-$abi $common $kbuild" >&2
(cd "$dir/debs" && apt_get download -q "linux-image-$abi" "linux-headers-$abi" "$common" "$kbuild" $host_extra >&2) ||
    skip "apt-get download of kernel $abi and its headers failed (no access to a Debian mirror?)"
# The image: only vmlinuz and the module folders the test loads from (a tenth of its 400 MB).
for deb in "$dir"/debs/*.deb; do
    case ${deb##*/} in
    linux-image-*)
        dpkg-deb --fsys-tarfile "$deb" | tar -x -C "$dir/root" --wildcards './boot/vmlinuz-*' '*/modules.*' \
            '*/kernel/fs/configfs/*' '*/kernel/drivers/usb/*' '*/kernel/drivers/mtd/*' 2>/dev/null || true
        ;;
    *) dpkg-deb -x "$deb" "$dir/root" ;;
    esac
done
[ -f "$dir/root/boot/vmlinuz-$abi" ] || { echo "vm_prepare: no vmlinuz in linux-image-$abi" >&2; exit 1; }
rm -rf "$dir/debs"
# The per-flavour Makefile includes the common tree by its installed path: point it here.
echo "include $dir/root/usr/src/$common/Makefile" >"$headers/Makefile"
cc=$(sed -n 's/^CC = .*\(gcc-[0-9][0-9]*\)$/\1/p' "$headers/.kernelvariables")
if [ -n "$cc" ] && ! command -v "$cc" >/dev/null; then
    [ "$suite" != bookworm ] || skip "kernel $abi modules are built with $cc, which is not installed"
    kbuild_for_older_host "$cc"
fi

# Only the modules the test loads, in load order (dependencies first). trixie's packages put
# them in /usr/lib/modules (merged /usr), where depmod -b does not look.
[ -e "$dir/root/lib" ] || ln -s usr/lib "$dir/root/lib"
depmod -b "$dir/root" "$abi"
mkdir -p "$dir/modules"
: >"$dir/modules.order"
for m in configfs dummy_hcd libcomposite usb_f_fs mtd mtdram; do
    modprobe --show-depends -d "$dir/root" -S "$abi" "$m" | sed -n 's/^insmod \([^ ]*\).*/\1/p'
done | awk '!seen[$0]++' | while read -r ko; do
    cp "$ko" "$dir/modules/"
    case $ko in # trixie compresses its modules; busybox insmod takes them plain
    *.ko.xz) xz -d "$dir/modules/${ko##*/}" ;;
    *.ko.zst) zstd -q -d --rm "$dir/modules/${ko##*/}" ;;
    esac
    name=${ko##*/}
    echo "${name%.ko*}.ko" >>"$dir/modules.order"
done
echo wdrvb.ko >>"$dir/modules.order"
cp "$dir"/root/boot/vmlinuz-"$abi" "$dir/vmlinuz"
# The rest of the image is 400 MB of modules nobody loads here: keep the headers only.
rm -rf "$dir/root/boot" "$dir/root/lib" "$dir/root/usr/lib/modules"
touch "$dir/kernel.ready"
}

[ -f "$dir/kernel.ready" ] || fetch_kernel

# The virtual board, built against those headers; its pins come from vboard/vboard_pins.h.
mod=$dir/wdrvb
mkdir -p "$mod"
for f in "$src/tests/vm/vboard/wdrvb.c" "$src/tests/vm/vboard/vboard_model.h" "$src/tests/vm/vboard/vboard_pins.h"; do
    cmp -s "$f" "$mod/${f##*/}" || cp "$f" "$mod/" # unchanged sources keep kbuild incremental
done
# driver_override moved into struct device in the 6.12 stable series: tell the module which.
compat=
grep -q 'device_set_driver_override' "$dir"/root/usr/src/linux-headers-*-common/include/linux/device.h &&
    compat='ccflags-y += -DVB_DEVICE_DRIVER_OVERRIDE'
printf 'obj-m := wdrvb.o\n%s\n' "$compat" >"$mod/Kbuild.new"
cmp -s "$mod/Kbuild.new" "$mod/Kbuild" || mv "$mod/Kbuild.new" "$mod/Kbuild"
cc_override=()
[ -x "$dir/cc" ] && cc_override=("CC=$dir/cc")
make -s -C "$headers" M="$mod" "${cc_override[@]}" modules >"$dir/wdrvb-build.log" 2>&1 || {
    cat "$dir/wdrvb-build.log" >&2
    echo "vm_prepare: wdrvb.ko does not build against linux-headers-$abi" >&2
    exit 1
}

cp "$mod/wdrvb.ko" "$dir/modules/"
# What this kernel's build needed, for the VM table's "where the kernels differ".
{
    if [ -n "$compat" ]; then where="in struct device"; else where="in spi_device"; fi
    echo "module_compat driver_override $where; chip select $(grep -q 'SPI_CS_CNT_MAX' "$dir"/root/usr/src/linux-headers-*-common/include/linux/spi/spi.h && echo "slots: 16 per device, unused ones marked invalid" || echo "one per device")"
    kcc=$(sed -n 's/^CC = .*\(gcc-[0-9][0-9]*\)$/\1/p' "$headers/.kernelvariables")
    if [ -x "$dir/cc" ]; then echo "module_toolchain gcc-12 for the kernel's $kcc, its host tools on $suite's libc"
    else echo "module_toolchain the kernel's own $kcc"; fi
    echo "gpio_uapi v2 $(grep -q '^CONFIG_GPIO_CDEV=y' "$headers/.config" && echo yes || echo no), v1 $(grep -q '^CONFIG_GPIO_CDEV_V1=y' "$headers/.config" && echo yes || echo no)"
    echo "modules_compressed $(grep -q '^CONFIG_MODULE_COMPRESS_XZ=y' "$headers/.config" && echo xz || echo no)"
} >"$dir/notes.txt"
echo "$abi"
