#!/usr/bin/env python3
"""Replays a run's log through two estimates of the end: the one the run
printed (read back from the log) and the per-class estimate of
src/pipeline/progress.rs (`wall_left`), re-implemented here so that a log
recorded before that estimate existed can be judged by it.

Usage: scripts/eta-replay.py RUN_LOG PLAN_TXT
  RUN_LOG   .repro/log/run-UNIXSECONDS-PID.log of a finished run
  PLAN_TXT  the output of `repro plan --all --profile P` for the same build
            (the planned CPU seconds of each simulation; other stages at
            their kind's mean)

Prints, at 0-90% of the run, how far each estimate of the end was from the
actual end (as a share of the run), and the largest error of the per-class
estimate from a tenth of the run on. Standard library only.
"""
import os
import re
import statistics
import sys

CLASS_EVIDENCE, CLASS_PRIOR, WORKERS = 20.0, 30.0, 2


def read_plan(path):
    sims, kinds, sec = {}, {}, None
    for line in open(path):
        if line.startswith("simulation (per run)"):
            sec = "sim"
            continue
        if line.startswith("other stages"):
            sec = "other"
            continue
        f = line.split()
        try:
            if sec == "sim" and len(f) == 7:
                sims[f[0]] = float(f[-1])
            elif sec == "other" and len(f) == 3:
                kinds[f[0]] = float(f[2]) / float(f[1])
        except ValueError:
            pass
    return sims, kinds


def main(log, plan):
    name = re.match(r"run-0*(\d+)-\d+\.log$", os.path.basename(os.path.realpath(log)))
    if not name:
        sys.exit(f"eta-replay: {log} is not a run log (run-UNIXSECONDS-PID.log)")
    start = int(name[1])
    sims, kinds = read_plan(plan)
    if not sims:
        sys.exit(f"eta-replay: {plan} has no simulation table (the output of `repro plan`)")

    def planned(label, kind):
        if kind == "simulate":
            cfg = re.sub(r",?replica=\d+", "", label).replace("[]", "")
            return sims.get(cfg, sims.get(label.split("[")[0], 1.0))
        return kinds.get(kind, 0.01)

    ev = []
    for line in open(log):
        m = re.match(r"\[\s*([\d.]+) s\] \[\d+/\d+\] (executed) (\S+) \((\w+)\) in ([\d.]+) s", line)
        if m:
            ev.append(("fin", float(m[1]), m[3], m[4], float(m[5])))
        m = re.match(r"\[\s*([\d.]+) s\] running (\S+) for [\d.]+ s: (\d+)% \((\w+)", line)
        if m:
            ev.append(("run", float(m[1]), m[2], float(m[3]) / 100, m[4]))
        m = re.match(r"\[\s*([\d.]+) s\] .*ends ~(\d+):(\d+):(\d+)", line)
        if m:
            ev.append(("eta", float(m[1]), int(m[2]) * 3600 + int(m[3]) * 60 + int(m[4]) - start % 86400))
    if not any(e[0] == "fin" for e in ev):
        sys.exit(f"eta-replay: {log} has no finished stage")
    end = max(e[1] for e in ev)
    stages = {e[2]: (e[3], planned(e[2], e[3]), e[1] - e[4], e[1]) for e in ev if e[0] == "fin"}

    def estimate(t):
        last = {}
        for e in ev:
            if e[1] > t:
                break
            if e[0] == "run":
                last[e[2]] = (e[3], e[4])
        classes, busy, left = {}, 0.0, []
        for lab, (kind, p, st, fn) in stages.items():
            c = kind + ":" + lab.split("[")[0]
            if fn <= t:
                k = classes.setdefault(c, [0.0, 0.0])
                k[0] += p
                k[1] += fn - st
                busy += fn - st
            elif st <= t:
                f, msg = last.get(lab, (0.0, ""))
                busy += t - st
                if f >= 0.02 and not msg.startswith(("Relax", "Compress")):
                    k = classes.setdefault(c, [0.0, 0.0])
                    k[0] += p * f
                    k[1] += t - st
                left.append((c, p * (1 - f)))
            else:
                left.append((c, p))
        rates = [s / p for p, s in classes.values() if p >= CLASS_EVIDENCE]
        machine = statistics.median(rates) if rates else 1.0
        cpu = longest = 0.0
        for c, p in left:
            k = classes.get(c, [0.0, 0.0])
            x = p * (k[1] + CLASS_PRIOR * machine) / (k[0] + CLASS_PRIOR)
            cpu += x
            longest = max(longest, x)
        share = min(1.0, max(0.5, busy / (t * WORKERS))) if t > 60 and busy > 0 else 1.0
        return t + max(cpu / (WORKERS * share), longest)

    def shrunk(t):
        # The estimate the run printed until this commit (the measured pace
        # over all stages, shrunk towards the plan's with the plan weighing a
        # tenth of the work), replayed: how close the replay comes to what
        # was printed says how far to trust the per-class replay.
        total = sum(v[1] for v in stages.values())
        last = {}
        for e in ev:
            if e[1] > t:
                break
            if e[0] == "run":
                last[e[2]] = e[3]
        left = [p * (1 - last.get(lab, 0.0)) if st <= t else p
                for lab, (kind, p, st, fn) in stages.items() if fn > t]
        prior = 0.1 * total
        pace = (t + prior / WORKERS) / (total - sum(left) + prior)
        return t + max(sum(left) * pace, max(left + [0.0]) * pace * WORKERS)

    printed = [(e[1], e[2]) for e in ev if e[0] == "eta"]
    print(f"run of {end:.0f} s, {len(stages)} stages executed")
    for frac in (0.0, 0.1, 0.2, 0.5, 0.9):
        t = max(frac * end, 1.0)
        p = [v for s, v in printed if s <= t]
        was = f"{100 * (p[-1] - end) / end:+.0f}%" if p else "none"
        print(
            f"at {100 * frac:3.0f}%: printed {was:>6}, shrunk (replayed) {100 * (shrunk(t) - end) / end:+.0f}%, "
            f"per class {100 * (estimate(t) - end) / end:+.0f}%"
        )
    worst = max(abs(estimate(e[1]) - end) for e in ev if e[1] >= 0.1 * end)
    print(f"per class: largest error from a tenth of the run on {100 * worst / end:.0f}% of the run")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
