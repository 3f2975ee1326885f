#!/bin/bash
# The installed programs work from anywhere and never read the source tree (issue 22):
# `cmake --install` into a DESTDIR stage, then every program run from another folder with no
# WDR_* variable set, under strace: boards and scenes by name, an unknown name listing the known
# ones, WDR_SCENES_DIR, wdr-hdrgen's --help, --version and man page, EXAMPLES in every man page,
# completion of values, every transport in the --device help, one output-name rule; a simulated
# board started by name and driven by wdrctl. No file is copied from the source tree.
# usage: staged_install.sh BUILD_DIR SOURCE_DIR
set -u
build=$(realpath "$1") src=$(realpath "$2")
tmp=$(mktemp -d)
pid=
trap 'exec 4>&-; [ -n "$pid" ] && wait $pid 2>/dev/null; rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

DESTDIR=$tmp/stage cmake --install "$build" --prefix /usr >"$tmp/install.log" 2>&1 || fail "install: $(cat "$tmp/install.log")"
stage=$tmp/stage/usr
echo "staged: $(cd "$tmp/stage" && find . -type f | sort | tr '\n' ' ')"
hits=$(grep -rlF "$src" "$tmp/stage")
[ -z "$hits" ] || fail "installed files name the source tree $src: $hits"

work=$tmp/elsewhere
mkdir -p "$work" && cd "$work" || fail "no work folder"
unset WDR_BOARDS_DIR WDR_SCENES_DIR WDR_DEVICE
export PATH=$stage/bin:/usr/bin:/bin CI=1
trace=
command -v strace >/dev/null && trace=$tmp/trace
# run EXPECTED_RC PROG ARGS...: the installed program, traced; its output in $out
run() {
    local want=$1
    shift
    echo "\$ $*"
    if [ -n "$trace" ]; then
        out=$(strace -f -qq -e trace=%file -o "$trace.$$.$RANDOM" "$@" 2>&1)
    else
        out=$("$@" 2>&1)
    fi
    local rc=$?
    printf '%s\n' "$out" | sed 's/^/  /' | head -8
    [ "$rc" = "$want" ] || fail "'$*' exited $rc, expected $want"
}

run 0 wdr-hdrgen --version
run 0 wdr-hdrgen --help
run 0 wdr-hdrgen -o pano.exr --size 64x32
run 64 wdr-hdrgen -o pano.png
run 0 wdrsim --board sim-qvga --scene window --operator reinhard -o w.png
run 64 wdrsim --board sim-qvga --scene window --operator reinhard -o w.tiff
printf '%s' "$out" | grep -q "must end in .pfm or .png" || fail "wdrsim -o w.tiff: no rule named"
run 64 wdrctl capture -o w.tiff
printf '%s' "$out" | grep -q "must end in .png or .pfm" || fail "wdrctl capture -o w.tiff: no rule named"
run 66 wdr-simboard --board sim-vgaa --scene window --socket b.sock
printf '%s' "$out" | grep -q "known: .*sim-qvga, sim-vga" || fail "unknown board: the known ones are not listed"
run 66 wdrsim --board sim-qvga --scene windw --operator reinhard -o w.png
printf '%s' "$out" | grep -q "known: .*window" || fail "unknown scene: the known ones are not listed"
mkdir -p my-scenes && cp "$stage/share/wdrcam/scenes/uniform.json" my-scenes/flat.json
WDR_SCENES_DIR=$work/my-scenes run 0 wdrsim --board sim-qvga --scene flat --operator reinhard -o f.pfm
run 0 wdrctl lut build --operator reinhard -o default.lut          # the default board, by name
run 0 wdrctl info --help
for t in sim: usb serial: unix: tcp:; do
    printf '%s' "$out" | grep -q -- "$t" || fail "the --device help does not name $t"
done

# a simulated board by name, driven by the installed wdrctl; it ends when its stdin (a pipe)
# closes, which reaches it through strace too
mkfifo board.in
if [ -n "$trace" ]; then
    strace -f -qq -e trace=%file -o "$trace.board" wdr-simboard --board sim-qvga --scene window --socket b.sock \
        <board.in 2>board.log &
else
    wdr-simboard --board sim-qvga --scene window --socket b.sock <board.in 2>board.log &
fi
pid=$!
exec 4>board.in
export WDR_DEVICE=sim:$work/b.sock
run 0 wdrctl info --wait 10000
run 0 wdrctl lut build --board sim-qvga --operator reinhard -o r.lut
run 0 wdrctl lut upload r.lut
run 0 wdrctl capture -o frame.png
run 0 wdrctl stream -n 1
exec 4>&-
wait $pid 2>/dev/null
pid=

# man pages: every program's, with EXAMPLES
for p in wdrctl wdrsim wdr-simboard wdr-hdrgen; do
    page=$stage/share/man/man1/$p.1
    [ -s "$page" ] || fail "no man page for $p"
    MANWIDTH=100 man -l "$page" 2>/dev/null | grep -q "^EXAMPLES" || fail "$p.1 has no EXAMPLES"
done
echo "man pages: EXAMPLES in each of wdrctl wdrsim wdr-simboard wdr-hdrgen"

# completion of values, through the installed scripts and programs
complete_words() { # PROG WORDS...: the candidates bash offers for the last word
    local prog=$1
    shift
    bash -c '. "$0"; COMP_WORDS=("$@"); COMP_CWORD=$(($# - 1)); _$(echo "${1//-/_}"); printf "%s\n" "${COMPREPLY[@]}"' \
        "$stage/share/bash-completion/completions/$prog" "$prog" "$@"
}
c=$(complete_words wdrctl lut build --board sim-) && echo "$c" | grep -qx sim-qvga || fail "wdrctl --board sim-: got '$c'"
c=$(complete_words wdrctl lut build --operator rein) && echo "$c" | grep -qx reinhard_white || fail "--operator rein: got '$c'"
c=$(complete_words wdrctl calibrate --model s) && echo "$c" | grep -qx simple3 || fail "--model s: got '$c'"
c=$(complete_words wdrctl info --device s) && echo "$c" | grep -qx serial: || fail "--device s: got '$c'"
c=$(complete_words wdr-simboard --scene w) && echo "$c" | grep -qx window || fail "wdr-simboard --scene w: got '$c'"
echo "completion: boards, operators, models, devices, scenes"

if [ -n "$trace" ]; then
    read_src=$(cat "$trace".* | grep -F "\"$src" | head -5)
    [ -z "$read_src" ] || fail "an installed program touched the source tree: $read_src"
    echo "strace: no installed program opened or looked at a path under $src"
else
    echo "strace missing: the source-tree check is the installed files' contents only"
fi
echo "staged install: ok"
