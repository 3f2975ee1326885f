#!/bin/sh
# Mbed TLS's source for the Cortex-M7 build, from Debian bookworm's source package (the release
# the host links as libmbedtls-dev: 2.28.3 today, or a bookworm update of it), cached in the
# build folder:
#   fetch_mbedtls.sh DEST
# Fetches with a private sources list, package lists and cache under DEST (the system's apt
# configuration is never touched), then unpacks the upstream tarball. On success prints the
# source folder (DEST/mbedtls-<version>); a second run finds it and fetches nothing.
# Fails with one line on stderr when the package cannot be fetched (no mirror, no apt) or is not
# a 2.28 release (mbedtls_config_m7.h is written for 2.28's options).
set -eu
dest=$1
fail() { echo "fetch_mbedtls: $*" >&2; exit 1; }

for ready in "$dest"/mbedtls-*/.wdr-ready; do
    if [ -f "$ready" ]; then
        dirname "$ready"
        exit 0
    fi
done
command -v apt-get >/dev/null || fail "apt-get not found: cannot fetch Debian's mbedtls source package"
apt=$dest/apt
rm -rf "$apt" && mkdir -p "$apt/lists/partial" "$apt/cache/archives/partial" "$apt/get"
echo "deb-src http://deb.debian.org/debian bookworm main" >"$apt/sources.list"
# Everything apt writes goes under DEST; running as root, apt's _apt user cannot read DEST.
set -- -q -o "Dir::Etc::sourcelist=$apt/sources.list" -o Dir::Etc::sourceparts=/dev/null \
    -o "Dir::State::Lists=$apt/lists" -o "Dir::Cache=$apt/cache" -o APT::Sandbox::User=root
apt-get "$@" update >"$apt/update.log" 2>&1 ||
    fail "apt-get update of bookworm's sources failed (no access to deb.debian.org?), see $apt/update.log"
(cd "$apt/get" && apt-get "$@" source --download-only mbedtls) >"$apt/source.log" 2>&1 ||
    fail "apt-get source mbedtls failed, see $apt/source.log"
set -- "$apt"/get/mbedtls_*.orig.tar.gz
tarball=$1
[ -f "$tarball" ] || fail "no mbedtls_*.orig.tar.gz in $apt/get after apt-get source"
release=${tarball##*/mbedtls_}
release=${release%.orig.tar.gz}
case $release in 2.28.*) ;; *) fail "bookworm's mbedtls is $release, not a 2.28 release" ;; esac
src=$dest/mbedtls-$release
rm -rf "$src" && mkdir -p "$src"
tar xzf "$tarball" -C "$src" --strip-components=1 || fail "cannot unpack $tarball"
grep -q "MBEDTLS_VERSION_STRING *\"$release\"" "$src/include/mbedtls/version.h" ||
    fail "$tarball is not Mbed TLS $release (include/mbedtls/version.h)"
rm -rf "$apt"
touch "$src/.wdr-ready"
echo "$src"
