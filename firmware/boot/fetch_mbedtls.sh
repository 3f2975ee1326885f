#!/bin/sh
# Mbed TLS's source for the Cortex-M7 build, from Debian's source package (the release the host
# links as libmbedtls-dev), cached in the build folder:
#   fetch_mbedtls.sh DEST
# Fetches with a private sources list, package lists and cache under DEST (the system's apt
# configuration is never touched), then unpacks the upstream tarball. On success prints the
# source folder (DEST/mbedtls-<version>); a second run finds it and fetches nothing.
# Fails with one line on stderr when the package cannot be fetched (no mirror, no apt).
set -eu
dest=$1
release=2.28.3 # bookworm's; the config header (mbedtls_config_m7.h) is written for 2.28
src=$dest/mbedtls-$release
fail() { echo "fetch_mbedtls: $*" >&2; exit 1; }

if [ -f "$src/.wdr-ready" ]; then
    echo "$src"
    exit 0
fi
command -v apt-get >/dev/null || fail "apt-get not found: cannot fetch Debian's mbedtls source package"
apt=$dest/apt
rm -rf "$apt" "$src" && mkdir -p "$apt/lists/partial" "$apt/cache/archives/partial" "$apt/get"
echo "deb-src http://deb.debian.org/debian bookworm main" >"$apt/sources.list"
# Everything apt writes goes under DEST; running as root, apt's _apt user cannot read DEST.
set -- -q -o "Dir::Etc::sourcelist=$apt/sources.list" -o Dir::Etc::sourceparts=/dev/null \
    -o "Dir::State::Lists=$apt/lists" -o "Dir::Cache=$apt/cache" -o APT::Sandbox::User=root
apt-get "$@" update >"$apt/update.log" 2>&1 ||
    fail "apt-get update of bookworm's sources failed (no access to deb.debian.org?), see $apt/update.log"
(cd "$apt/get" && apt-get "$@" source --download-only "mbedtls=$release-1") >"$apt/source.log" 2>&1 ||
    fail "apt-get source mbedtls=$release-1 failed, see $apt/source.log"
tarball=$apt/get/mbedtls_$release.orig.tar.gz
[ -f "$tarball" ] || fail "no $tarball after apt-get source"
mkdir -p "$src"
tar xzf "$tarball" -C "$src" --strip-components=1 || fail "cannot unpack $tarball"
grep -q "MBEDTLS_VERSION_STRING *\"$release\"" "$src/include/mbedtls/version.h" ||
    fail "$tarball is not Mbed TLS $release (include/mbedtls/version.h)"
rm -rf "$apt"
touch "$src/.wdr-ready"
echo "$src"
