#!/bin/sh
# usage: cli_docs.sh MAN_PAGE COMPLETION PROGRAM README
# The generated man page is valid troff and names every option `PROGRAM --help` lists; it has
# EXAMPLES, each of them a command the README shows (so the two cannot drift apart); the
# generated bash completion loads and completes an option prefix.
man=$1 completion=$2 prog=$3 readme=$4
fail() { echo "FAIL: $*"; exit 1; }
[ -s "$man" ] || fail "$man missing or empty"
if command -v groff >/dev/null 2>&1; then
    warnings=$(groff -man -ww -z "$man" 2>&1)
    [ -z "$warnings" ] || fail "groff warns on $man: $warnings"
fi
# Every long option in the program's help (and its commands' help) is in the man page.
help=$("$prog" --help)
cmds=$(printf '%s\n' "$help" | sed -n '/^commands:/,/^$/p' | sed -n 's/^  \([a-z][a-z]*\( [a-z][a-z]*\)\?\)  .*/\1/p')
for c in "" $(printf '%s\n' "$cmds" | tr ' ' '+'); do
    words=$(printf '%s' "$c" | tr '+' ' ')
    # shellcheck disable=SC2086
    for opt in $("$prog" $words --help | grep -o -- '--[a-z][a-z0-9-]*' | sort -u); do
        esc=$(printf '%s' "$opt" | sed 's/-/\\\\-/g')
        grep -q -- "$esc" "$man" || fail "$man lacks $opt (of '$prog $words --help')"
    done
done
# EXAMPLES: every line (its command, without a trailing comment) is in the README, whose
# backslash-continued lines are joined and spaces squeezed first.
examples=$(sed -n '/^\.SH "EXAMPLES"/,/^\.fi/p' "$man" | sed '1,2d;$d' | sed 's/\\-/-/g; s/  *#.*//; s/ *&$//')
[ -n "$examples" ] || fail "$man has no EXAMPLES"
flat=$(sed -e ':a' -e '/\\$/N; s/\\\n[[:space:]]*/ /; ta' "$readme" | tr -s ' ')
printf '%s\n' "$examples" | while IFS= read -r ex; do
    printf '%s\n' "$flat" | grep -qF -- "$ex" || fail "$man: example '$ex' is not in $readme"
done || exit 1
bash -c ". '$completion' && complete -p $(basename "$prog") >/dev/null" || fail "$completion does not load"
echo "ok: $man names every option of '$(basename "$prog") --help'; $completion loads"
