"""The numpy Q(t) against the built-in `overlap` kind's at every (phi, t)
both have: a row per point with both values and their difference; the stage
fails if any differs by more than `tolerance` or no point is shared."""

import json
import os
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

args = json.load(open(os.environ["REPRO_PARAMS"]))
tables = {}
for i in json.load(open(os.environ["REPRO_INPUTS"])):
    tables[i["stage"]] = pq.read_table(i["files"]["parquet"]).to_pandas()
mine, builtin = tables["q_numpy_table"], tables["q_builtin_table"]
both = mine.merge(builtin[["phi", "t", "Q"]], on=["phi", "t"], suffixes=("_numpy", "_builtin"))
both["diff"] = both["Q_numpy"] - both["Q_builtin"]
worst = float(np.abs(both["diff"]).max()) if len(both) else float("nan")
print(f"{len(both)} points shared of {len(mine)} numpy and {len(builtin)} built-in; largest |difference| {worst:.3g}")
out = pa.table({c: both[c].to_numpy() for c in ["phi", "t", "Q_numpy", "Q_builtin", "diff"]})
pq.write_table(out, os.path.join(os.environ["REPRO_OUT"], "check.parquet"))
if not len(both) or not worst <= args["tolerance"]:
    sys.exit(f"the numpy Q(t) differs from the built-in's by {worst} (tolerance {args['tolerance']})")
