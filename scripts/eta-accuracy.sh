#!/usr/bin/env bash
# How close a run's estimate of its end came to the actual end: reads a run's
# log (default .repro/log/LAST-RUN.log, a link to run-UNIXSECONDS-PID.log,
# whose name gives the start), takes every line's elapsed time and printed end
# (`ends ~HH:MM:SS UTC`), and the last line's elapsed time as the actual end.
# Prints the error of the estimate at 0, 10, 20, 50 and 90% of the run and
# the largest from a tenth on, as a share of the run's duration.
set -euo pipefail
log=${1:-.repro/log/LAST-RUN.log}
real=$(readlink -f "$log")
start=$(basename "$real" | sed -nE 's/^run-0*([0-9]+)-[0-9]+\.log$/\1/p')
if [ -z "$start" ]; then
    echo "eta-accuracy: $log is not a run log (run-UNIXSECONDS-PID.log)" >&2
    exit 1
fi
sed -nE 's/^\[ *([0-9.]+) s\].*ends ~([0-9]{2}):([0-9]{2}):([0-9]{2}) UTC.*/\1 \2 \3 \4/p; s/^\[ *([0-9.]+) s\].*/\1/p' "$real" |
    awk -v start="$start" '
    NF == 4 { n++; t[n] = $1; e = $2 * 3600 + $3 * 60 + $4 - start % 86400
              if (e < -43200) e += 86400; eta[n] = e }
    { last = $1 }
    END {
        if (n == 0) { print "eta-accuracy: no estimate in the log" > "/dev/stderr"; exit 1 }
        d = last
        printf "run of %.0f s, %d estimates\n", d, n
        split("0 0.1 0.2 0.5 0.9", f, " ")
        for (k = 1; k <= 5; k++)
            for (i = 1; i <= n; i++) if (t[i] >= f[k] * d) {
                printf "at %3.0f%% (%.0f s): end printed %+.0f s from the actual (%+.0f%% of the run)\n",
                    100 * f[k], t[i], eta[i] - d, 100 * (eta[i] - d) / d
                break
            }
        w = 0
        for (i = 1; i <= n; i++) if (t[i] >= 0.1 * d) { x = eta[i] - d; if (x < 0) x = -x; if (x > w) w = x }
        printf "largest error from a tenth of the run on: %.0f s, %.0f%% of the run\n", w, 100 * w / d
    }'
