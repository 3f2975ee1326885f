#!/bin/sh
# gnuplot's messages are captured (issue 22): a warning from a gnuplot that succeeds never
# reaches the terminal, and the error of one that fails is in wdrctl's message. A fake gnuplot
# (WDR_GNUPLOT) plays both; then the real one draws a plot with nothing on stderr.
# usage: plot_messages.sh WDRCTL [fakes-only]   (fakes-only: the sanitizers' run, no real gnuplot)
set -u
wdrctl=$(realpath "$1")
real=${2:-real}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
printf '#!/bin/sh\ncat >/dev/null\necho "warning: all points y value undefined" >&2\necho PNGBYTES\nexit 0\n' >"$dir/warns"
printf '#!/bin/sh\ncat >/dev/null\necho "line 7: undefined variable: bogus" >&2\nexit 1\n' >"$dir/fails"
chmod +x "$dir/warns" "$dir/fails"
cd "$dir" || exit 1
WDR_GNUPLOT=$dir/warns "$wdrctl" lut build --operator reinhard -o r.lut --plot r.png >out.txt 2>err.txt ||
    fail "a gnuplot that warns made lut build fail: $(cat err.txt)"
! grep -q "warning\|PNGBYTES" out.txt err.txt || fail "gnuplot's output leaked: $(cat out.txt err.txt)"
echo "a warning of a gnuplot that succeeds: not shown"
WDR_GNUPLOT=$dir/fails "$wdrctl" lut build --operator reinhard -o r.lut --plot r.png >out.txt 2>err.txt &&
    fail "a gnuplot that fails: lut build succeeded"
grep -q "undefined variable: bogus" err.txt || fail "the failing gnuplot's message is not reported: $(cat err.txt)"
echo "a failing gnuplot: $(cat err.txt)"
if [ "$real" != fakes-only ] && command -v gnuplot >/dev/null; then
    "$wdrctl" lut plots --outdir plots >out.txt 2>err.txt || fail "lut plots: $(cat err.txt)"
    [ ! -s err.txt ] || fail "lut plots wrote to stderr: $(cat err.txt)"
    [ -s plots/vref_all.png ] || fail "no plots/vref_all.png (a missing --outdir is created)"
    echo "lut plots into a new folder: nothing on stderr"
fi
echo "plot messages: ok"
