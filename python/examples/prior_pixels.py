"""Where the planar prior helps and where it hurts, pixel by pixel: run ACMM and ACMMP on
the ICL living room, keep every view's maps at the end of each stage of the finest scale,
and score them against the ground truth on the pixels that got a prior and on the others.

    python python/examples/prior_pixels.py --out prior.png          # 320x240, 5 views
    python python/examples/prior_pixels.py --small --out prior.png  # CI: 96x72, 3 views
"""

import argparse
import json
import pathlib
import warnings

import matplotlib

matplotlib.use("Agg")  # write a file; in a notebook, leave this out
import matplotlib.pyplot as plt
import numpy as np

import mvscope

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--out", default="prior_pixels.png", help="the figure")
parser.add_argument("--small", action="store_true", help="a quick run: 96x72, 3 views")
parser.add_argument("--seed", type=int, default=0)
parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="an ACMMP parameter, e.g. prior_lock=true (repeatable)")
parser.add_argument("--room", type=pathlib.Path, help="the scene (default: the shared ICL room)",
                    default=pathlib.Path(__file__).resolve().parents[2].parent
                    / "shared/data/rgbd/icl-livingroom")
args = parser.parse_args()

room = args.room
warnings.simplefilter("ignore", mvscope.SceneWarning)  # "downscaled to 320 px"
if args.small:
    scene = mvscope.Scene.open(room, max_image_size=96, views=[0, 3, 4])
else:
    scene = mvscope.Scene.open(room, max_image_size=320)


def value(text):
    """A --set value as params.toml writes it: true, 3, 0.5, or a word."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


changes = {name: value(v) for name, v in (item.split("=", 1) for item in args.set)}


def truth(view, shape):
    """The view's ground truth at the maps' size, nearest pixel (as `mvscope eval`)."""
    gt = mvscope.read_pfm(room / "gt" / f"{view.scene_index:08d}.pfm")
    # Halves round up, as the CLI rounds (numpy's round would take them to even).
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * gt.shape[0] / shape[0]), 0, gt.shape[0] - 1)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * gt.shape[1] / shape[1]), 0, gt.shape[1] - 1)
    return gt[np.ix_(rows.astype(int), cols.astype(int))]


def finest_scale(method, params):
    """Every view's maps at the end of each stage of the finest scale."""
    session = mvscope.Session(scene, method=method, seed=args.seed, params=params)
    last = session.num_levels - 1
    ends = {}  # stage -> steps run when its last step has run
    for step in session.steps:
        if step["level"] == last:
            ends[step["stage"]] = step["index"] + 1
    stages = {}
    for stage, cursor in sorted(ends.items(), key=lambda item: item[1]):
        session.goto(cursor)
        stages[stage] = [session.maps(view.index) for view in scene.views]
    return stages


acmm = finest_scale("acmm", {})
acmmp = finest_scale("acmmp", changes)
truths = [truth(view, acmm["detail restorer"][i]["depth"].shape) for i, view in enumerate(scene.views)]


def right(depths):
    """Per view: the pixels within 2% of the truth."""
    return [(d > 0) & (np.abs(d - g) <= 0.02 * g) for d, g in zip(depths, truths)]


def share(hits, masks):
    n = sum(int(m.sum()) for m in masks)
    return 100.0 * sum(int((h & m).sum()) for h, m in zip(hits, masks)) / max(n, 1), n


valid = [g > 0 for g in truths]
prior = [(m["prior_depth"] > 0) & v for m, v in zip(acmmp["planar prior"], valid)]
others = [~p & v for p, v in zip(prior, valid)]
print(f"{share(prior, valid)[0]:.1f}% of the pixels with ground truth get a prior at the finest scale")
print(f"the prior's depth is within 2% of the truth on "
      f"{share(right(m['prior_depth'] for m in acmmp['planar prior']), prior)[0]:.1f}% of them")
print(f"{'within 2%':<24}{'prior pixels':>14}{'the others':>12}{'all':>8}")
for name, stages in [("ACMM", acmm), ("ACMMP", acmmp)]:
    for stage, maps in stages.items():
        hits = right(m["depth"] for m in maps)
        cells = [share(hits, masks)[0] for masks in (prior, others, valid)]
        print(f"{name + ' ' + stage:<24}" + "".join(f"{c:>{w}.1f}" for c, w in zip(cells, (14, 12, 8))))

# Pixels the prior stage turned from right to wrong, and how many the geometric passes mended.
before = right(m["depth"] for m in acmmp["detail restorer"])
after = right(m["depth"] for m in acmmp["planar prior"])
final = right(m["depth"] for m in acmmp[list(acmmp)[-1]])
prior_right = right(m["prior_depth"] for m in acmmp["planar prior"])
lost = [b & ~a & v for b, a, v in zip(before, after, valid)]
n_lost = share(lost, lost)[1]
print(f"the prior stage made {n_lost} right pixels wrong; the prior itself was right on "
      f"{share(prior_right, lost)[0]:.1f}% of them, and the geometric passes mended "
      f"{share(final, lost)[0]:.1f}%")

view = 0
fig, axes = plt.subplots(1, 4, figsize=(18, 4))
gt = truths[view]
for ax, (title, depth) in zip(axes[:3], [
    ("ACMMP, detail restorer", acmmp["detail restorer"][view]["depth"]),
    ("ACMMP, planar prior stage", acmmp["planar prior"][view]["depth"]),
    ("ACMM, last geometric pass", acmm[list(acmm)[-1]][view]["depth"]),
]):
    error = np.where((depth > 0) & (gt > 0), (depth - gt) / np.where(gt > 0, gt, 1), np.nan)
    im = ax.imshow(error, cmap="coolwarm", vmin=-0.05, vmax=0.05)
    ax.set_title(f"{title}\nrelative error, ±5%")
    ax.set_axis_off()
fig.colorbar(im, ax=axes[:3].tolist(), shrink=0.8)
overlay = np.zeros(gt.shape + (3,))
overlay[prior[view]] = (0.6, 0.6, 0.6)
overlay[lost[view]] = (1.0, 0.2, 0.2)
axes[3].imshow(overlay)
axes[3].set_title("view 0: prior (grey),\nright → wrong in the prior stage (red)")
axes[3].set_axis_off()
fig.savefig(args.out, dpi=100, bbox_inches="tight")
print(f"saved {args.out}")
