#!/bin/sh
# Rebuild the committed seed corpora: generated tables, files, sessions and reproducers
# (fuzz_make_seeds), the real scenes, and LUTs wdrctl builds for the real boards.
# usage: tests/fuzz/make_seeds.sh BUILD_DIR   (a configured build, e.g. build)
set -eu
here=$(cd "$(dirname "$0")" && pwd); top=$(cd "$here/../.." && pwd); build=$1
corpus=$here/corpus
cmake --build "$build" --target fuzz_make_seeds wdrctl -j2 >/dev/null
for t in fw_rx fw_update lut cal boot scene images client image; do mkdir -p "$corpus/$t"; done
"$build/tests/fuzz/fuzz_make_seeds" "$corpus"
for s in "$top"/sim/scenes/*.json; do cp "$s" "$corpus/scene/$(basename "$s")"; done
export WDR_BOARDS_DIR="$top/boards"
for b in sim-qvga ideal-linear; do
  for op in reinhard logarithmic; do
    "$build/host/wdrctl" lut build --board "$b" --operator "$op" -o "$corpus/lut/wdrctl_${b}_${op}.lut" >/dev/null
  done
done
# fw_image: signed images (the development key) of a 16- and a 100-byte application, one signed
# by another key, one cut short, one with a flipped application byte.
mkdir -p "$corpus/fw_image"
key=$top/firmware/boot/keys/dev-signing-key.NOT-FOR-PRODUCTION.pem
tmp=$(mktemp -d)
head -c 16 /dev/zero > "$tmp/a16.bin"; head -c 100 /dev/urandom > "$tmp/a100.bin"
"$build/host/wdrctl" fw sign --key "$key" "$tmp/a16.bin" -o "$corpus/fw_image/dev16.img" --version 1.0.0+1 >/dev/null
"$build/host/wdrctl" fw sign --key "$key" "$tmp/a100.bin" -o "$corpus/fw_image/dev112.img" --version 2.3.4+5 \
    --security-counter 7 --board mps2-an500 --load-addr 0x00020000 --ram-load off >/dev/null
openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$tmp/other.pem" 2>/dev/null
"$build/host/wdrctl" fw sign --key "$tmp/other.pem" "$tmp/a16.bin" -o "$corpus/fw_image/other16.img" >/dev/null
head -c 150 "$corpus/fw_image/dev16.img" > "$corpus/fw_image/cut16.img"
cp "$corpus/fw_image/dev16.img" "$corpus/fw_image/flip16.img"
printf '\001' | dd of="$corpus/fw_image/flip16.img" bs=1 seek=70 conv=notrunc 2>/dev/null
rm -rf "$tmp"
echo "seeds in $corpus"
