#!/usr/bin/env bash
# Debian 12 packages the project needs. As root, installs what is missing; otherwise prints
# the exact apt-get line and fails. Sourced by .ci/demo and .ci/test.
WDR_PACKAGES="build-essential cmake pkg-config libcjson-dev libpng-dev libstb-dev libopenexr-dev \
libcmocka-dev libusb-1.0-0-dev libgpiod-dev gnuplot-nox gcc-arm-none-eabi libnewlib-arm-none-eabi \
clang-tidy cppcheck groff-base strace qemu-system-arm gdb-multiarch parallel jq bc \
qemu-system-x86 busybox-static cpio kmod xz-utils systemd v4l-utils clang-14 libclang-rt-14-dev \
libmbedtls-dev libssl-dev openssl valgrind"
# firmware/boot/fetch_mbedtls.sh fetches the source of Debian's mbedtls for the Cortex-M7 into build-m7
# (apt-get source through a private sources list, no install).
# tests/vm also fetches Debian's current kernels (bookworm's from the system's lists, trixie's
# and libgpiod 2.x from bookworm-backports through a private sources list in the build folder)
# with apt-get download, no install; it builds its module with gcc-12. systemd: for
# systemd-analyze verify of wdr-board.service (tests/linux), xz-utils: trixie's modules.
# tests/vm/v4l2 also downloads and builds Debian's v4l2loopback-dkms source the same way;
# v4l-utils gives v4l2-ctl, strace serves the staged-install test (tests/host/staged_install.sh).

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
