#!/usr/bin/env bash
# Mutation check: plant each fault below in a copy of the sources, build the calibration tests
# into their own build folder, run them, and report whether some test caught the fault.
# usage: bash tests/torture/mutate.sh [WORKDIR] [NUMBER ...]   (default build-mutation/, all)
# Not run in CI by default: one mutation costs an incremental build and ~2-4 minutes of tests.
set -uo pipefail
cd "$(dirname "$0")/../.."
root=$PWD
work=$(realpath -m "${1:-build-mutation}")
shift || true
only=" $* "

# number @ file @ sed expression @ what the fault does
mutations=(
"1@host/cal/stats/cal_bad.c@s/else if (!(swing >= cfg->dead_frac \* med_swing))/else if (0 \&\& !(swing >= cfg->dead_frac * med_swing))/@flagging: dead pixels never flagged"
"2@host/cal/stats/cal_bad.c@s/med_dark - lv->dark\[i\] > limit/med_dark - lv->dark[i] > 1e9 * limit/@flagging: hot pixels never flagged"
"3@host/cal/stats/cal_bad.c@s/if (y <= 0.5 || y >= cfg->raw_max - 0.5)/if (0)/@flagging: saturated pixels never flagged"
"4@host/cal/fit/cal_fit_spline.c@s/if (y\[k\] > y\[k - 1\] + tol\[k\])/if (y[k] > y[k - 1] + 1e9 * tol[k])/;s/if (fabs(y\[k\] - out\[k\]) > t)/if (fabs(y[k] - out[k]) > 1e9 * t)/@fit: reversed pixels accepted"
"5@host/cal/fit/cal_fit.c@s/        if (st) {/        if (st || i % 10) {/@fit: 90 % of good pixels marked unfit (the issue's plant)"
"6@host/cal/stats/cal_stats.c@s/return cfg->tie_codes + cfg->tie_sigmas \* sqrt/return cfg->tie_codes + 0 * sqrt/@statistics: tie tolerance ignores the measured noise"
"7@host/cal/stats/cal_stats.c@s/while (nb > 1 \&\& mean\[nb - 1\] > mean\[nb - 2\])/while (0)/@statistics: no pooling of reversals"
"8@host/cal/metrics/cal_select.c@s/if (!(worst < best->worst_pct))/if (!(worst > best->worst_pct))/@selection: keeps the worst set of currents"
"9@host/cal/metrics/cal_select.c@s/if (!(fabs(med\[idx\[j - 1\]\] - med\[idx\[j\]\]) > need))/if (!(fabs(med[idx[j - 1]] - med[idx[j]]) > -need))/@selection: levels closer than a DAC step + 3 sigma accepted"
"10@host/cal/table/cal_table.c@s/flags\[i\] = res->flags\[i\];/flags[i] = 0;/;s/flags\[i\] |= flags\[i\] ? 0 : WDR_PIX_UNFIT;/flags[i] |= 0;/@table: no pixel marked bad in the table (none concealed)"
"11@host/cal/fit/cal_residual.c@s/lim->limit = res->cfg.tie_sigmas \* lim->noise_ln + lim->misfit;/lim->limit = 0.05;/@fit: lsq/polymap residual against a fixed 5 % (the old rule)"
"12@host/cal/fit/cal_residual.c@s/lim->limit = res->cfg.tie_sigmas \* lim->noise_ln + lim->misfit;/lim->limit = INFINITY;/@fit: lsq/polymap accept any residual"
"13@host/cal/fit/cal_model.c@s/#define GN_MAX_STEPS 50/#define GN_MAX_STEPS 0/@fit: paper models' least squares takes no Gauss-Newton step"
"14@host/cal/table/cal_basis.c@s/#define DENSE_CODES 256 /#define DENSE_CODES 0 /;s/#define SMOOTH_PENALTY 1e-6/#define SMOOTH_PENALTY 1e-4/@table: basis learnt from log-spaced currents only (the old learner)"
)
tests='^(test_torture|test_cal_maths|test_cal_defects|test_cal_flags_curve|test_cal_sim|test_cal_paper_lsq|test_cal_endslope)$'
targets="test_torture test_cal_maths test_cal_defects test_cal_flags_curve test_cal_sim test_cal_paper_lsq test_cal_endslope"

mkdir -p "$work/src"
git ls-files -z | xargs -0 cp --parents -t "$work/src"   # the sources as committed
cp -a --parents $(git diff --name-only) "$work/src" 2>/dev/null || true   # and as edited
cmake -S "$work/src" -B "$work/build" -DCMAKE_BUILD_TYPE=Release >/dev/null || exit 1
cmake --build "$work/build" -j2 --target $targets >/dev/null || { echo "unmutated build fails"; exit 1; }
printf '%-3s %-60s %-8s %s\n' "#" "planted fault" "result" "failing tests"
missed=0
for m in "${mutations[@]}"; do
    IFS='@' read -r num file expr what <<<"$m"
    [[ "$only" == "  " || "$only" == *" $num "* ]] || continue
    cp "$root/$file" "$work/src/$file"
    sed -i "$expr" "$work/src/$file"
    if cmp -s "$root/$file" "$work/src/$file"; then
        printf '%-3s %-60s %-8s %s\n' "$num" "$what" "NOT-APPLIED" "(the sed found nothing: update the list)"
        missed=$((missed + 1)); continue
    fi
    if ! cmake --build "$work/build" -j2 --target $targets >/dev/null 2>&1; then
        # a fault that does not compile proves nothing about the tests: fix the mutation
        printf '%-3s %-60s %-8s %s\n' "$num" "$what" "BROKEN" "(does not build: update the list)"
        missed=$((missed + 1))
    else
        log=$(ctest --test-dir "$work/build" -R "$tests" -j2 2>&1)
        failed=$(grep -E '^\s+[0-9]+ - ' <<<"$log" | sed -E 's/^\s+[0-9]+ - ([^ ]+).*/\1/' | tr '\n' ' ')
        if [ -n "$failed" ]; then
            printf '%-3s %-60s %-8s %s\n' "$num" "$what" "caught" "$failed"
        else
            printf '%-3s %-60s %-8s %s\n' "$num" "$what" "MISSED" ""
            missed=$((missed + 1))
        fi
    fi
    cp "$root/$file" "$work/src/$file"
done
cmake --build "$work/build" -j2 --target $targets >/dev/null 2>&1
echo "missed: $missed"
exit $((missed > 0))
