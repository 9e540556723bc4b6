#!/usr/bin/env bash
# Would CI notice a small change of the physics, and does it stay quiet without
# one? Builds the CI figures at the ci profile with each change (and with none)
# at fresh master seeds (never used for the goldens), checks each build against
# tests/golden/ci.json with `repro regress`, and prints what fires and the rate.
#
#   make sensitivity                          eps 0.88, radius ratio 1.40, none; seeds 901-903
#   CHANGES="eps=0.85" SEEDS="901 902" make sensitivity
#
# Each build is one `repro regress --profile ci --seed S --set CHANGE` (about
# 4-10 min on 2 cores); the log of every build is kept in results/sensitivity/.
set -uo pipefail
cd "$(dirname "$0")/.."
REPRO=${REPRO:-"cargo run --release --locked --quiet --"}
SEEDS=${SEEDS:-"901 902 903"}
CHANGES=${CHANGES:-"eps=0.88 radius_ratio=1.40 none"}
JOBS_FLAG=${JOBS:+--jobs $JOBS}
out=results/sensitivity
mkdir -p "$out"
summary=()
for change in $CHANGES; do
    fired=0 runs=0
    for seed in $SEEDS; do
        set_flag=()
        [ "$change" != none ] && set_flag=(--set "$change")
        log="$out/${change//[^A-Za-z0-9_.=-]/_}-seed$seed.log"
        echo "== $change at master seed $seed (log: $log)"
        # shellcheck disable=SC2086
        $REPRO regress --profile ci --seed "$seed" "${set_flag[@]}" $JOBS_FLAG ${FIGURES:-} >"$log" 2>&1
        rc=$?
        runs=$((runs + 1))
        if [ $rc -ne 0 ]; then
            fired=$((fired + 1))
            echo "   FIRES:"
            grep -E "^(regression|.*key number .* has neither)|jointly" "$log" | sed 's/^/     /' | head -20
        else
            echo "   quiet"
        fi
        grep -E "^joint:" "$log" | sed 's/^/   /'
    done
    summary+=("$change: CI fails at $fired of $runs fresh seeds")
done
echo
echo "== sensitivity of the CI regression (seeds: $SEEDS)"
printf '%s\n' "${summary[@]}" | tee "$out/summary.txt"
