#!/usr/bin/env bash
# wdr-board on libgpiod 2.x, for the VM test: libgpiod-dev and its library from
# bookworm-backports (apt-get download through a private sources list, dpkg-deb -x into the
# build folder, the .pc prefix moved there), then this source tree configured against it
# (PKG_CONFIG_PATH, WDR_HAL_LINUX=ON) and only wdr-board built.
#   gpiod2_build.sh SOURCE_DIR OUT_DIR [CMAKE_ARGS...]
# Prints the path of that wdr-board. Exit 77 (skip) when no mirror answers.
set -euo pipefail
src=$1 out=$2
shift 2
. "$src/tests/vm/private_apt.sh"
root=$out/root
if [ ! -f "$out/unpacked" ]; then
    papt_init "$out/apt" "deb http://deb.debian.org/debian bookworm-backports main" ||
        { echo "SKIP: apt-get update of bookworm-backports failed (no Debian mirror?)" >&2; exit 77; }
    # libgpiod-dev names its library package (libgpiod3 for 2.1, libgpiod2 for 2.0).
    lib=$(papt_cache depends libgpiod-dev/bookworm-backports 2>/dev/null | sed -n 's/^ *Depends: \(libgpiod[0-9]\+\)$/\1/p' | head -1)
    [ -n "$lib" ] || { echo "SKIP: bookworm-backports has no libgpiod-dev" >&2; exit 77; }
    rm -rf "$out/debs" "$root" && mkdir -p "$out/debs" "$root"
    (cd "$out/debs" && papt_get download "libgpiod-dev/bookworm-backports" "$lib/bookworm-backports" >&2) ||
        { echo "SKIP: apt-get download libgpiod-dev $lib failed" >&2; exit 77; }
    for deb in "$out"/debs/*.deb; do dpkg-deb -x "$deb" "$root"; done
    # The .pc says prefix=/usr: point it at the unpacked tree.
    for pc in "$root"/usr/lib/*/pkgconfig/libgpiod.pc; do
        sed -i "s#^prefix=/usr\$#prefix=$root/usr#" "$pc"
    done
    ls "$out"/debs >"$out/unpacked"
fi
pcdir=$(dirname "$(ls "$root"/usr/lib/*/pkgconfig/libgpiod.pc)")
echo "gpiod2_build: $(PKG_CONFIG_PATH=$pcdir pkg-config --modversion libgpiod) from $(tr '\n' ' ' <"$out/unpacked")" >&2
PKG_CONFIG_PATH=$pcdir cmake -S "$src" -B "$out/build" -DWDR_HAL_LINUX=ON "$@" >"$out/configure.log" 2>&1 ||
    { cat "$out/configure.log" >&2; exit 1; }
grep 'hal/linux' "$out/configure.log" >&2
cmake --build "$out/build" -j2 --target wdr-board >"$out/build.log" 2>&1 || { tail -30 "$out/build.log" >&2; exit 1; }
echo "$out/build/host/wdr-board"
