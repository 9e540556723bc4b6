"""Paper H's overlap Q(t) (Eq. 5-7, the whole system as one box) from the
trajectories of one packing fraction, with numpy and pyarrow only.

A disk is slow over [t0, t0 + t] if it moved less than `a`; Q(t) is the
fraction of slow disks, averaged over every time origin t0 of every replica.
Origins are the schedule's (in each trajectory's metadata); the lags are those
of the first replica's frames, as the built-in `overlap` kind takes them."""

import json
import os

import numpy as np
import pyarrow.parquet as pq

REL_TOL = 1e-6  # matching a lag to frame time differences


def frames(path):
    """Frame times, positions (frames x disks x 2) and the recording schedule."""
    table = pq.read_table(path, columns=["frame", "t", "id", "x", "y"])
    meta = json.loads(pq.read_metadata(path).metadata[b"repro.trajectory"])
    n = meta["particles"]
    t = table.column("t").to_numpy()[::n]
    xy = np.stack([table.column("x").to_numpy(), table.column("y").to_numpy()], axis=-1)
    return t, xy.reshape(len(t), n, 2), meta["schedule"]


def origins(t, schedule):
    """Indices of the frames at the schedule's time origins."""
    out = []
    for k in range(schedule["origins"]):
        t0 = schedule["start"] + k * schedule["origin_spacing"]
        tol = 1e-9 * max(abs(t0), 1.0)
        i = np.searchsorted(t, t0 - tol)
        if i < len(t) and abs(t[i] - t0) <= tol:
            out.append(i)
    return out


def lags(t):
    """Every lag of the frames after the first, near-equal ones once."""
    out = []
    for x in t[1:] - t[0]:
        if not out or abs(x - out[-1]) > max(REL_TOL, 1e-12) * abs(out[-1]):
            out.append(x)
    return out


def main():
    args = json.load(open(os.environ["REPRO_PARAMS"]))
    a2 = args["a"] ** 2
    runs = pq.read_table(os.environ["REPRO_RUNS"]).to_pandas()
    data = [frames(p) for p in runs["path"]]
    rows = []
    for lag in lags(data[0][0]):
        slow = []
        for t, xy, schedule in data:
            for i in origins(t, schedule):
                target = t[i] + lag
                j = np.searchsorted(t, target - REL_TOL * lag)
                if j < len(t) and j > i and abs(t[j] - target) <= REL_TOL * lag:
                    d2 = ((xy[j] - xy[i]) ** 2).sum(axis=1)
                    slow.append(np.mean(d2 < a2))
        if slow:
            rows.append((lag, float(np.mean(slow))))
    t, q = (np.array(c) for c in zip(*rows))
    import pyarrow as pa

    pq.write_table(pa.table({"t": t, "Q": q}), os.path.join(os.environ["REPRO_OUT"], "q.parquet"))


main()
