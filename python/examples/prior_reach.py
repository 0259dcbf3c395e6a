"""Where Regions' prior reaches and why it does not: run Regions on the ICL living room to the
end of the finest scale's prior stage, and sort every weak-texture pixel by what its prior
is (right or wrong within 2% of the truth) or, without one, why (Session.prior_mesh).

    python python/examples/prior_reach.py --out reach.png          # 320x240, 5 views
    python python/examples/prior_reach.py --small --out reach.png  # CI: 96x72, 3 views
"""

import argparse
import pathlib
import warnings

import matplotlib

matplotlib.use("Agg")  # write a file; in a notebook, leave this out
import matplotlib.pyplot as plt
import numpy as np

import mvscope

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--out", default="prior_reach.png", help="the figure")
parser.add_argument("--small", action="store_true", help="a quick run: 96x72, 3 views")
parser.add_argument("--seed", type=int, default=0)
parser.add_argument("--room", type=pathlib.Path, help="the scene (default: the shared ICL room)",
                    default=pathlib.Path(__file__).resolve().parents[2].parent
                    / "shared/data/rgbd/icl-livingroom")
args = parser.parse_args()

room = args.room
warnings.simplefilter("ignore", mvscope.SceneWarning)  # "downscaled to 320 px"
size, views = (96, [0, 3, 4]) if args.small else (320, None)
scene = mvscope.Scene.open(room, max_image_size=size, views=views)


def resized(path, shape):
    """A truth file at the maps' size, nearest pixel (as `mvscope eval`)."""
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0]), 0, a.shape[0] - 1)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1]), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]


s = mvscope.Session(scene, method="regions", seed=args.seed)
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)

CLASSES = {  # name: colour in the figure
    "prior within 2%": (0.1, 0.7, 0.2),
    "prior wrong": (0.9, 0.1, 0.1),
    "flat, its region has no plane": (0.2, 0.3, 0.9),
    "flat, its plane leaves the depth range": (0.8, 0.2, 0.8),
    "not flat, its plane leaves the depth range": (0.5, 0.2, 0.4),
    "not flat, its triangle dropped": (1.0, 0.6, 0.0),
    "not flat, past the hull": (0.5, 0.5, 0.5),
}
counts = dict.fromkeys(CLASSES, 0)
figure_view = None
for v in scene.views:
    m, mesh = s.maps(v.index), s.prior_mesh(v.index)
    gt = resized(room / "gt" / f"{v.scene_index:08d}.pfm", (m.height, m.width))
    weak = resized(room / "gt" / f"{v.scene_index:08d}_lowtex.png", (m.height, m.width)) & (gt > 0)
    r = mesh["regions"]
    rows, cols = np.arange(m.height)[:, None] // r["cell"], np.arange(m.width) // r["cell"]
    region, plane = r["region"][rows, cols], r["plane"][rows, cols]
    prior = m["prior_depth"]
    right = (prior > 0) & (np.abs(prior - gt) <= 0.02 * gt)
    # prior_depth's codes where there is none: 0 no triangle, -1 dropped, -2 out of range.
    # Outside the flat regions a pixel's plane is its triangle's or, past the hull (Regions'
    # prior_extend), its nearest support points'; either may leave the depth range.
    masks = {
        "prior within 2%": right,
        "prior wrong": (prior > 0) & ~right,
        "flat, its region has no plane": (prior <= 0) & (region > 0) & (plane < 0),
        "flat, its plane leaves the depth range": (prior == -2) & (plane >= 0),
        "not flat, its plane leaves the depth range": (prior == -2) & (region == 0),
        "not flat, its triangle dropped": (prior == -1) & (region == 0),
        "not flat, past the hull": (prior == 0) & (region == 0),
    }
    for name, mask in masks.items():
        counts[name] += int((mask & weak).sum())
    # The classes share no pixel and leave none out.
    assert sum(mask & weak for mask in masks.values()).max() <= 1
    assert sum(int((mask & weak).sum()) for mask in masks.values()) == int(weak.sum())
    if figure_view is None:
        picture = v.image() / 255.0 * 0.35
        for name, mask in masks.items():
            picture[mask & weak] = CLASSES[name]
        figure_view = (v.index, picture)

total = sum(counts.values())
print(f"Regions, {len(scene)} views at {size} px, seed {args.seed}: weak-texture pixels")
for name, n in counts.items():
    print(f"  {name:<44} {100 * n / max(total, 1):5.1f}%")

fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.2))
a.imshow(figure_view[1])
a.set_title(f"view {figure_view[0]}: weak pixels by what the prior gave them")
a.axis("off")
b.barh(list(counts)[::-1], [100 * n / max(total, 1) for n in counts.values()][::-1],
       color=list(CLASSES.values())[::-1])
b.set_xlabel("% of the weak-texture pixels, all views")
fig.tight_layout()
fig.savefig(args.out, dpi=90)
print(f"wrote {args.out}")
