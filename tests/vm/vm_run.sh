#!/usr/bin/env bash
# The VM test run (CTest vm_boot): kernel and module (vm_prepare.sh, cached), tables, an
# initramfs with busybox, the programs and their libraries, then one qemu-system-x86_64 boot
# under TCG that runs vm_init.sh. Writes OUT_DIR/results.txt (one "name PASS|FAIL detail" line
# per check, read by vm_check.sh) and OUT_DIR/console.log.
#   vm_run.sh SOURCE_DIR OUT_DIR WDR_BOARD WDRCTL VM_BOARD_MODEL VM_USBPROBE [V4L2_COMPARE]
# Exit 77 (CTest skip) with the reason when the machine lacks something the VM needs.
set -euo pipefail
src=$1 out=$2
bins=("$3" "$4" "$5" "$6")
skip() { echo "SKIP: $*" >&2; echo "SKIP $*" >"$out/results.txt"; exit 77; }
mkdir -p "$out"
rm -f "$out/results.txt"
t_start=$(date +%s.%N)
for tool in qemu-system-x86_64:qemu-system-x86 cpio:cpio ldd:libc-bin; do
    command -v "${tool%%:*}" >/dev/null || skip "${tool%%:*} not found (Debian package ${tool##*:})"
done
busybox=$(command -v busybox || true)
[ -n "$busybox" ] && ! ldd "$busybox" >/dev/null 2>&1 || skip "a static busybox is needed (Debian package busybox-static)"

rc=0
abi=$("$src/tests/vm/vm_prepare.sh" "$out/cache" "$src") || rc=$?
[ $rc = 77 ] && skip "kernel or headers unavailable (see above)"
[ $rc = 0 ] || exit $rc
kdir=$out/cache/$abi
"$src/tests/vm/v4l2/prepare.sh" "$kdir" "$abi" || echo "vm_run: no v4l2loopback: the V4L2 checks will say SKIP" >&2

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
for b in "${bins[@]}"; do
    cp "$b" "$root/usr/bin/"
    ldd "$b" | grep -o '/[^ ]*' | while read -r lib; do
        mkdir -p "$root$(dirname "$lib")"
        cp -L "$lib" "$root$lib"
    done
done
cp "$kdir"/modules/*.ko "$root/lib/modules/"
cp "$kdir/modules.order" "$root/lib/modules/order"
cp "$out/test.lut" "$out/test.cal" "$root/data/"
"$src/tests/vm/v4l2/stage.sh" "$root" "$kdir" "${7:-/nonexistent/v4l2_compare}"
# 32 MiB of NOR-like flash in 64 KiB blocks: two LUT and two calibration slots of a VGA board.
printf 'CAL_GAIN=%s\nMTD_KIB=32768\nMTD_ERASE_KIB=64\n' $cal_gain >"$root/data/params.env"
(cd "$root" && find . | cpio -o -H newc --quiet) >"$out/initramfs.cpio"
t_ready=$(date +%s.%N)

# TCG on purpose: CI machines have no KVM. The guard timeout only stops a hung VM.
timeout 720 qemu-system-x86_64 -accel tcg -cpu max -smp 2 -m 768 -nographic -no-reboot \
    -kernel "$kdir/vmlinuz" -initrd "$out/initramfs.cpio" \
    -append "console=ttyS0 panic=-1 quiet loglevel=4 rdinit=/init" \
    </dev/null >"$out/console.log" 2>&1 || true
t_end=$(date +%s.%N)

sed -n 's/^@@RESULT \([^ ]*\) \([A-Z]*\) \(.*\)\r\?$/\1 \2 \3/p' "$out/console.log" | tr -d '\r' >"$out/results.txt"
if grep -q '^@@DONE' "$out/console.log"; then
    echo "vm_done PASS the VM ran every check" >>"$out/results.txt"
else
    echo "vm_done FAIL the VM did not finish (see $out/console.log)" >>"$out/results.txt"
fi
awk -v a="$t_start" -v b="$t_ready" -v c="$t_end" -v k="$abi" \
    'BEGIN { printf "prepare %.1f s, VM %.1f s, total %.1f s, kernel %s\n", b - a, c - b, c - a, k }' | tee "$out/timing.txt"
sed 's/^/  /' "$out/results.txt"
