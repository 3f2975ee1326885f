#!/bin/sh
# A study run as 4 shards by GNU parallel and merged equals the same study run once, point for
# point (the figures measured here with a clock, CPU times per point, left out: they differ from
# run to run); a merge missing a shard is refused by the shard's number.
#   study_shards.sh WDRCTL STUDY.json OUTDIR
set -eu
ctl=$1 study=$2 out=$3
rm -rf "$out" && mkdir -p "$out"
args="--study $study --size 32x24 --no-plots --jobs 1"
t0=$(date +%s.%N)
"$ctl" study $args --outdir "$out/single" --json > "$out/single.json"
t1=$(date +%s.%N)
parallel --halt now,fail=1 "$ctl" study $args --outdir "$out/shards" --shard {}/4 ::: 1 2 3 4
t2=$(date +%s.%N)
"$ctl" study --merge "$out"/shards/shard-*.wshd --no-plots --outdir "$out/merged" --json > "$out/merged.json"
echo "single run $(echo "$t1 - $t0" | bc) s, 4 shards under parallel $(echo "$t2 - $t1" | bc) s (wall)"
strip='[.points[] | del(.cost.correct_ns_per_pixel, .cost.fit_s_per_megapixel, .used.eval_s)]'
jq -S "$strip" "$out/single.json" > "$out/single.points"
jq -S "$strip" "$out/merged.json" > "$out/merged.points"
[ "$(jq length "$out/single.points")" -gt 0 ] || { echo "FAIL: no points"; exit 1; }
cmp -s "$out/single.points" "$out/merged.points" || { echo "FAIL: merged points differ"; diff "$out/single.points" "$out/merged.points" | head; exit 1; }
echo "merged study.json equals the single run, $(jq length "$out/single.points") points"
rm "$out/shards/shard-3-of-4.wshd"
if "$ctl" study --merge "$out"/shards/shard-*.wshd --no-plots --outdir "$out/bad" 2> "$out/missing.err"; then
    echo "FAIL: a merge without shard 3 succeeded"; exit 1
fi
grep -q "shard 3/4 missing" "$out/missing.err" || { echo "FAIL: message"; cat "$out/missing.err"; exit 1; }
echo "a missing shard is refused: $(cat "$out/missing.err")"
