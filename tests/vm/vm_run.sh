#!/usr/bin/env bash
# The VM test run of one kernel (CTest vm_boot_SUITE): kernel and module (vm_prepare.sh,
# cached), wdr-board also built on libgpiod 2.x (gpiod2_build.sh, cached), tables, an initramfs
# with busybox, the programs, their libraries and wdr-gadget, then one qemu-system-x86_64 boot
# under TCG that runs vm_init.sh. Writes OUT_DIR/SUITE/results.txt (one "name PASS|FAIL|SKIP
# detail" line per check, read by vm_check.sh), facts.txt (vm_table.sh), console.log, timing.txt.
#   vm_run.sh SOURCE_DIR OUT_DIR SUITE WDR_BOARD WDRCTL VM_BOARD_MODEL VM_USBPROBE V4L2_COMPARE [CMAKE_ARGS...]
# SUITE: bookworm (Debian 12, 6.1) or trixie (Debian 13, 6.12). CMAKE_ARGS configure the
# libgpiod 2.x build like this one (build type, flags). V4L2_COMPARE:
# tests/host/v4l2_compare, for the V4L2 checks (tests/vm/v4l2). WDR_VM_QUICK=1: only the self-tests,
# bring-up and a raw capture per build (for planted-fault runs).
# Exit 77 (CTest skip) with the reason when the machine lacks something the VM needs.
set -euo pipefail
src=$1 top=$2 suite=$3
bins=("$4" "$5" "$6" "$7")
v4l2_compare=$8
shift 8
out=$top/$suite
skip() { echo "SKIP: $*" >&2; echo "SKIP $*" >"$out/results.txt"; exit 77; }
mkdir -p "$out"
rm -f "$out/results.txt" "$out/facts.txt"
t_start=$(date +%s.%N)
for tool in qemu-system-x86_64:qemu-system-x86 cpio:cpio ldd:libc-bin; do
    command -v "${tool%%:*}" >/dev/null || skip "${tool%%:*} not found (Debian package ${tool##*:})"
done
busybox=$(command -v busybox || true)
[ -n "$busybox" ] && ! ldd "$busybox" >/dev/null 2>&1 || skip "a static busybox is needed (Debian package busybox-static)"

# wdr-board on libgpiod 2.x: one build shared by both kernels' runs (run one at a time).
gpiod2=
rc=0
gpiod2=$("$src/tests/vm/gpiod2_build.sh" "$src" "$top/gpiod2" "$@") || rc=$?
[ $rc = 0 ] || [ $rc = 77 ] || exit $rc
[ $rc = 0 ] || gpiod2=
t_gpiod2=$(date +%s.%N)

rc=0
abi=$("$src/tests/vm/vm_prepare.sh" "$top/cache-$suite" "$src" "$suite") || rc=$?
[ $rc = 77 ] && skip "kernel or headers unavailable (see above)"
[ $rc = 0 ] || exit $rc
kdir=$top/cache-$suite/$abi
"$src/tests/vm/v4l2/prepare.sh" "$kdir" "$abi" "$top/cache-$suite" "$suite" "$src" ||
    echo "vm_run: no v4l2loopback for $abi: the V4L2 checks will say SKIP" >&2

# Tables: a LUT built for the board's geometry, a calibration of gain 2 and a per-pixel offset.
cal_gain=2
"${bins[1]}" lut build --operator reinhard -o "$out/test.lut" >/dev/null
"${bins[2]}" cal "$out/test.cal" $cal_gain

# The initramfs: rebuilt every run (the programs change), uncompressed (faster under TCG).
root=$out/initramfs
rm -rf "$root" && mkdir -p "$root"/{bin,usr/bin,lib/modules,data,etc}
cp "$busybox" "$root/bin/busybox"
ln -s busybox "$root/bin/sh"
cp "$src/tests/vm/vm_init.sh" "$root/init"
chmod +x "$root/init"
copy_program() { # file [name in /usr/bin], with every library it loads at its own path
    cp "$1" "$root/usr/bin/${2:-}"
    ldd "$1" | grep -o '/[^ ]*' | while read -r lib; do
        mkdir -p "$root$(dirname "$lib")"
        cp -L "$lib" "$root$lib"
        # A library from the build folder (libgpiod 2.x) also goes where the loader looks by
        # default: the build folder's path may lie under /tmp, which the VM mounts over.
        case $lib in /lib/* | /lib64/* | /usr/lib/*) ;; *) mkdir -p "$root/lib/x86_64-linux-gnu" && cp -L "$lib" "$root/lib/x86_64-linux-gnu/" ;; esac
    done
}
for b in "${bins[@]}"; do
    copy_program "$b"
done
[ -z "$gpiod2" ] || copy_program "$gpiod2" wdr-board-gpiod2
cp "$src/hal/linux/wdr-gadget.sh" "$root/usr/bin/wdr-gadget"
cp "$src/boards/vm-wdrvb/wdr-board.json" "$root/data/vm-wdrvb.json"
cp "$kdir"/modules/*.ko "$root/lib/modules/"
cp "$kdir/modules.order" "$root/lib/modules/order"
cp "$out/test.lut" "$out/test.cal" "$root/data/"
"$src/tests/vm/v4l2/stage.sh" "$root" "$kdir" "$v4l2_compare"
# 32 MiB of NOR-like flash in 64 KiB blocks: two LUT and two calibration slots of a VGA board.
printf 'CAL_GAIN=%s\nMTD_KIB=32768\nMTD_ERASE_KIB=64\nVM_QUICK=%s\n' $cal_gain "${WDR_VM_QUICK:-}" >"$root/data/params.env"
(cd "$root" && find . | cpio -o -H newc --quiet) >"$out/initramfs.cpio"
t_ready=$(date +%s.%N)

# TCG on purpose: CI machines have no KVM. The guard timeout only stops a hung VM.
timeout 720 qemu-system-x86_64 -accel tcg -cpu max -smp 2 -m 768 -nographic -no-reboot \
    -kernel "$kdir/vmlinuz" -initrd "$out/initramfs.cpio" \
    -append "console=ttyS0 panic=-1 quiet loglevel=4 rdinit=/init" \
    </dev/null >"$out/console.log" 2>&1 || true
t_end=$(date +%s.%N)

sed -n 's/^@@RESULT \([^ ]*\) \([A-Z]*\) \(.*\)\r\?$/\1 \2 \3/p' "$out/console.log" | tr -d '\r' >"$out/results.txt"
sed -n 's/^@@FACT \([^ ]*\) \(.*\)\r\?$/\1 \2/p' "$out/console.log" | tr -d '\r' >"$out/facts.txt"
if grep -q '^@@DONE' "$out/console.log"; then
    echo "vm_done PASS the VM ran every check" >>"$out/results.txt"
else
    echo "vm_done FAIL the VM did not finish (see $out/console.log)" >>"$out/results.txt"
fi
awk -v a="$t_start" -v g="$t_gpiod2" -v b="$t_ready" -v c="$t_end" -v k="$abi" -v s="$suite" \
    'BEGIN { printf "%s: libgpiod 2.x build %.1f s, prepare %.1f s, boot and checks %.1f s, total %.1f s, kernel %s\n", s, g - a, b - g, c - b, c - a, k }' |
    tee "$out/timing.txt"
cat "$kdir/notes.txt" >>"$out/facts.txt" 2>/dev/null || true
echo "boot_s $(awk -v b="$t_ready" -v c="$t_end" 'BEGIN { printf "%.1f", c - b }')" >>"$out/facts.txt"
sed 's/^/  /' "$out/results.txt"
