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
echo "seeds in $corpus"
