#!/bin/sh
# The VM runs side by side: one row per check, one column per kernel (and libgpiod, for the
# main path's gpiod1_/gpiod2_ checks), then each boot's time, then where the kernels differ:
# a check that passed on one and not the other, and the facts each boot recorded (UDC, gpiochip,
# MTD, libgpiod). Fails when a check failed on any kernel.   vm_table.sh RUN_DIR SUITE...
dir=$1
shift
for s; do [ -f "$dir/$s/results.txt" ] || { echo "no $dir/$s/results.txt: vm_boot_$s did not run"; exit 1; }; done
if head -1 "$dir/$1/results.txt" | grep -q '^SKIP'; then head -1 "$dir/$1/results.txt"; exit 77; fi
awk -v suites="$*" -v dir="$dir" '
BEGIN {
    n = split(suites, S, " ")
    for (i = 1; i <= n; i++) {
        f = dir "/" S[i] "/results.txt"
        while ((getline line < f) > 0) {
            split(line, w, " ")
            if (!(w[1] in seen)) { seen[w[1]] = 1; order[++rows] = w[1] }
            v[w[1], i] = w[2]
        }
        f = dir "/" S[i] "/facts.txt"
        while ((getline line < f) > 0) {
            k = line; sub(/ .*/, "", k); val = line; sub(/^[^ ]* ?/, "", val)
            if (!(k in fseen)) { fseen[k] = 1; forder[++frows] = k }
            fv[k, i] = val
        }
    }
    printf "%-30s %-8s", "check", "libgpiod"
    for (i = 1; i <= n; i++) printf " %-10s", S[i]
    printf "\n"
    for (r = 1; r <= rows; r++) {
        c = order[r]; lib = "-"; name = c
        if (c ~ /^gpiod1_/) { lib = "1.x"; sub(/^gpiod1_/, "", name) }
        if (c ~ /^gpiod2_/) { lib = "2.x"; sub(/^gpiod2_/, "", name) }
        printf "%-30s %-8s", name, lib
        differ = 0
        for (i = 1; i <= n; i++) {
            x = ((c, i) in v) ? v[c, i] : "-"
            printf " %-10s", x
            if (x == "FAIL") bad++
            if (i > 1 && x != v[c, 1]) differ = 1
        }
        printf "%s\n", differ ? "  <- differs" : ""
        if (differ) diffs = diffs "  check " c "\n"
    }
    printf "\nboot and checks (s):"
    for (i = 1; i <= n; i++) printf " %s %s;", S[i], fv["boot_s", i]
    printf "\n\nfacts per kernel:\n"
    for (r = 1; r <= frows; r++) {
        k = forder[r]
        if (k == "boot_s") continue
        same = 1
        for (i = 2; i <= n; i++) if (fv[k, i] != fv[k, 1]) same = 0
        for (i = 1; i <= n; i++) printf "  %-18s %-9s %s\n", k, S[i], fv[k, i]
        if (!same && k != "init_at_s" && k != "checks_done_at_s") diffs = diffs "  fact " k "\n"
    }
    printf "\nwhere the kernels differ:\n%s", diffs ? diffs : "  nowhere (every check and fact the same)\n"
    exit bad ? 1 : 0
}'
