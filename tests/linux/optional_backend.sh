#!/bin/sh
# hal/linux is optional: with a libgpiod that pkg-config finds but that cannot be used (a 2.x
# .pc whose prefix holds nothing; then one pointing at the system's folders, where the 1.x
# header and library answer instead of 2.x ones), configure must
# succeed with one line saying why hal/linux is skipped; with -DWDR_HAL_LINUX=ON it must stop
# with that reason.   optional_backend.sh SOURCE_DIR SCRATCH_DIR
src=$1 dir=$2
rm -rf "$dir" && mkdir -p "$dir/pc"
cat >"$dir/pc/libgpiod.pc" <<'PC'
prefix=/nonexistent/usr
libdir=${prefix}/lib
includedir=${prefix}/include
Name: libgpiod
Description: a libgpiod 2.x that is not there
Version: 2.1.3
Libs: -L${libdir} -lgpiod
Cflags: -I${includedir}
PC
auto_skips() { # build folder, regex of the reason
    out=$(PKG_CONFIG_PATH=$dir/pc cmake -S "$src" -B "$dir/$1" 2>&1); rc=$?
    echo "$out" | grep 'hal/linux'
    [ $rc = 0 ] || { echo "FAIL: AUTO configure stopped (exit $rc)"; echo "$out" | grep -A3 Error | head; exit 1; }
    echo "$out" | grep -q "hal/linux (wdr-board) skipped: libgpiod 2.1.3.*$2" || { echo "FAIL: no skip line"; exit 1; }
}
auto_skips missing 'include folder /nonexistent/usr/include does not exist'
sed -i 's#^prefix=.*#prefix=/usr#' "$dir/pc/libgpiod.pc"
auto_skips v1_answers 'does not compile and link'

out=$(PKG_CONFIG_PATH=$dir/pc cmake -S "$src" -B "$dir/on" -DWDR_HAL_LINUX=ON 2>&1); rc=$?
[ $rc != 0 ] && echo "$out" | grep -q 'hal/linux is required' ||
    { echo "FAIL: WDR_HAL_LINUX=ON did not stop (exit $rc)"; exit 1; }
echo "WDR_HAL_LINUX=ON: configure stopped (exit $rc): hal/linux is required"
rm -rf "$dir"
