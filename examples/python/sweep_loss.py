# %% [markdown]
# # How much link loss does the formation take?
#
# A notebook in the percent format (Jupyter, VS Code, `jupytext --to ipynb`), also a plain
# script: `python examples/python/sweep_loss.py [--seeds 10] [--out DIR]`.
#
# It sweeps `links.loss` of the shipped glider mission over a few values, runs each value
# for several seeds in this process (`vbap.batch`, the same runs as `vbap batch
# --in-process`), and plots the share of seeds that converged with matplotlib.

# %%
import argparse
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import vbap

ROOT = Path(__file__).resolve().parents[2]
parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--seeds", type=int, default=10)
parser.add_argument("--jobs", type=int, default=2)
parser.add_argument("--out", type=Path, default=None, help="directory of the batch and the plot")
parser.add_argument("--duration", type=float, default=None, help="mission time, s")
args, _ = parser.parse_known_args()
out = args.out or Path(tempfile.mkdtemp(prefix="vbap-sweep-"))

# %% The sweep: one batch over a grid of loss values.
mission = ROOT / "deploy" / "missions" / "glider.toml"
losses = [0.0, 0.5, 0.8, 0.9, 0.95, 0.98]
sets = {} if args.duration is None else {"mission.duration": args.duration}
batch = vbap.batch(
    mission, seeds=args.seeds, sweep={"links.loss": losses}, set=sets, jobs=args.jobs,
    out=out / "batch",
)
table = batch.table
print(table[["links.loss", "seed", "converged", "final_distance_to_optimum"]].to_string())

# %% Success rate by loss, and the plot.
rate = table.groupby("links.loss")["converged"].mean()
fig, ax = plt.subplots(figsize=(5, 3.2))
ax.plot(rate.index, 100 * rate.values, marker="o")
ax.set_xlabel("link loss probability (links.loss)")
ax.set_ylabel(f"converged, % of {args.seeds} seeds")
ax.set_ylim(-5, 105)
ax.set_title(f"{mission.stem}: success rate against link loss")
fig.tight_layout()
picture = out / "success_rate.png"
fig.savefig(picture, dpi=120)
print(f"success rate by loss: {dict(rate.round(3))}")
print(f"plot: {picture}")
