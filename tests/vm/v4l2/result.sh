#!/bin/sh
# A V4L2 check of the VM run (checks.sh): as vm_check.sh, and a SKIP line (no v4l2loopback
# module or no v4l2-ctl on this machine) is a CTest skip (77) with its reason.
#   result.sh RESULTS_FILE NAME
line=$(grep "^$2 " "$1" 2>/dev/null | head -1)
case $line in
"$2 SKIP "*) echo "$line"; exit 77 ;;
esac
exec sh "$(dirname "$0")/../vm_check.sh" "$1" "$2"
