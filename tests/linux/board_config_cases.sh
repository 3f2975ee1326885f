#!/bin/sh
# Every bad board file of bad_boards/cases.txt must be refused by `wdr-board --check-config`
# with its exit code and a message naming the file, the field and the value; the boards/ files
# must be accepted.   board_config_cases.sh WDR_BOARD SOURCE_DIR
board=$1 src=$2 dir=$src/tests/linux/bad_boards fails=0 n=0
for good in "$src"/boards/*/wdr-board.json; do
    out=$("$board" --config "$good" --check-config 2>&1) || { echo "FAIL $good refused: $out"; fails=$((fails + 1)); }
done
tab=$(printf '\t')
while IFS="$tab" read -r name code regex; do
    case $name in '#'* | '') continue ;; esac
    n=$((n + 1))
    file=$dir/$name.json
    out=$("$board" --config "$file" --check-config 2>&1)
    rc=$?
    if [ $rc -ne "$code" ] || ! printf '%s\n' "$out" | grep -q -- "$file: $regex"; then
        echo "FAIL $name: exit $rc (want $code): $out"
        fails=$((fails + 1))
    else
        echo "ok   $name: $out"
    fi
done <"$dir/cases.txt"
echo "$n bad board files, $fails failures"
[ $fails -eq 0 ] && [ $n -ge 10 ]
