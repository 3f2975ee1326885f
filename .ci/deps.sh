#!/usr/bin/env bash
# Debian 12 packages the project needs. As root, installs what is missing; otherwise prints
# the exact apt-get line and fails. Sourced by .ci/demo and .ci/test.
WDR_PACKAGES="build-essential cmake pkg-config libcjson-dev libpng-dev libstb-dev libopenexr-dev \
libcmocka-dev libusb-1.0-0-dev libgpiod-dev gnuplot-nox gcc-arm-none-eabi libnewlib-arm-none-eabi \
clang-tidy cppcheck groff-base strace qemu-system-arm \
qemu-system-x86 busybox-static cpio kmod v4l-utils clang-14 libclang-rt-14-dev"
# tests/vm also fetches Debian's current kernel and its headers itself (apt-get download into the
# build folder, no install), and builds its module with the kernel's compiler (gcc-12).

wdr_missing_packages() {
    for p in $WDR_PACKAGES; do
        dpkg-query -W -f='${Status}\n' "$p" 2>/dev/null | grep -q "install ok installed" || printf '%s ' "$p"
    done
}

wdr_ensure_packages() {
    local missing
    missing=$(wdr_missing_packages)
    [ -z "$missing" ] && return 0
    if [ "$(id -u)" = 0 ]; then
        echo "Installing missing Debian packages: $missing"
        DEBIAN_FRONTEND=noninteractive apt-get update -qq &&
            DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $missing
    else
        echo "Missing Debian packages. Install them with:" >&2
        echo "  sudo apt-get install -y --no-install-recommends $missing" >&2
        return 1
    fi
}
