#!/bin/sh
# usage: cli_expect.sh EXPECTED_EXIT REGEX PROGRAM ARGS...
# Runs PROGRAM; passes when its exit code is EXPECTED_EXIT and its output matches REGEX.
want=$1; regex=$2; shift 2
out=$("$@" 2>&1); rc=$?
printf '%s\n' "$out"
[ "$rc" -eq "$want" ] || { echo "FAIL: exit $rc, expected $want"; exit 1; }
printf '%s\n' "$out" | grep -q -- "$regex" || { echo "FAIL: output lacks /$regex/"; exit 1; }
echo "ok: exit $rc and /$regex/"
