#!/bin/sh
# One check of the VM run: its line in results.txt (vm_run.sh). Exit 0 PASS, 1 FAIL or missing,
# 77 (CTest skip) when the VM run was skipped, with the reason.
#   vm_check.sh RESULTS_FILE NAME
results=$1 name=$2
[ -f "$results" ] || { echo "no $results: the VM run (test vm_boot) did not happen"; exit 1; }
if head -1 "$results" | grep -q '^SKIP'; then
    echo "$(head -1 "$results")"
    exit 77
fi
line=$(grep "^$name " "$results" | head -1)
[ -n "$line" ] || { echo "$name: no result: the VM stopped before this check (see console.log)"; exit 1; }
echo "$line"
case $line in
"$name PASS "*) exit 0 ;;
"$name SKIP "*) exit 77 ;;
*) exit 1 ;;
esac
