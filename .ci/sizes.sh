#!/bin/sh
# The longest files and the largest functions of the tree's C sources (git ls-files).
# usage: sh .ci/sizes.sh [N]   (N of each, default 5)
# A function is a '{' in column 0 up to the next '}' in column 0 (the code's clang-format
# style); its size counts the lines from its signature's first line to that '}'.
n=${1:-5}
cd "$(dirname "$0")/.." || exit 1
files=$(git ls-files '*.c' '*.h')
echo "longest files (lines):"
# shellcheck disable=SC2086
wc -l $files | grep -v ' total$' | sort -rn | head -n "$n" | awk '{ printf "  %5d  %s\n", $1, $2 }'
echo "largest functions (lines, signature to closing brace):"
# shellcheck disable=SC2086
awk '
FNR == 1 { sig = 0; in_fn = 0 }
!in_fn && /^[A-Za-z_].*\(/ { sig = FNR; sigtext = $0 }
!in_fn && /^[ \t]*$/ { sig = 0 }
/^\{/ && !in_fn && sig { in_fn = 1; start = sig; name = sigtext; next }
/^\}/ && in_fn {
    in_fn = 0
    sub(/\(.*/, "", name); k = split(name, w, /[ \t*]+/)
    printf "%d %s:%d %s\n", FNR - start + 1, FILENAME, start, w[k]
    sig = 0
}' $files | sort -rn | head -n "$n" | awk '{ printf "  %5d  %s  %s()\n", $1, $2, $3 }'
