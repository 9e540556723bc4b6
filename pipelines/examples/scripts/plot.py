"""Fig. 3 of paper H drawn with matplotlib from the numpy Q(t) table."""

import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pyarrow.parquet as pq

inputs = json.load(open(os.environ["REPRO_INPUTS"]))
q = pq.read_table(inputs[0]["files"]["parquet"]).to_pandas()
fig, ax = plt.subplots(figsize=(6, 4.5))
for phi, curve in q.groupby("phi"):
    ax.plot(curve["t"], curve["Q"], label=f"{phi:g}")
ax.axhline(1 / 2.718281828459045, color="grey", lw=0.8, ls="--")
ax.set(xscale="log", xlabel="t", ylabel="Q(t)", ylim=(0, 1))
ax.legend(title="φ", fontsize=8)
fig.tight_layout()
# No timestamp in the PNG: the same table gives the same bytes.
fig.savefig(os.path.join(os.environ["REPRO_OUT"], "fig3.png"), dpi=100, metadata={"Software": None})
