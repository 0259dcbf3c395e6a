import sys, warnings, pathlib
import numpy as np
import matplotlib; matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope
warnings.simplefilter("ignore")
out = pathlib.Path("/tmp/s25/bimodal/scene")
scene = mvscope.Scene.open(out)
seed = int(sys.argv[1]); V = int(sys.argv[2]) if len(sys.argv) > 2 else 0
s = mvscope.Session(scene, method="regions", seed=seed)
last = s.num_levels - 1
pri = max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior"))
s.goto(pri + 1)
res = {}
for v in scene.views:
    m, mesh = s.maps(v.index), s.prior_mesh(v.index)
    g = mvscope.read_pfm(out / "gt" / f"{v.scene_index:08d}.pfm")
    weak = (plt.imread(out / "gt" / f"{v.scene_index:08d}_lowtex.png") > 0) & (g > 0)
    r = mesh["regions"]
    rows, cols = np.arange(m.height)[:, None] // r["cell"], np.arange(m.width) // r["cell"]
    region, plane = r["region"][rows, cols], r["plane"][rows, cols]
    prior = m["prior_depth"]
    right = (prior > 0) & (np.abs(prior - g) <= 0.02 * g)
    masks = {
        "prior within 2%": right,
        "prior wrong": (prior > 0) & ~right,
        "flat, region no plane": (prior <= 0) & (region > 0) & (plane < 0),
        "flat, plane out of range": (prior == -2) & (plane >= 0),
        "not flat, out of range": (prior == -2) & (region == 0),
        "not flat, triangle dropped": (prior == -1) & (region == 0),
        "not flat, past hull": (prior == 0) & (region == 0),
    }
    n = weak.sum()
    print(f"v{v.index} weak {n} ({100*n/(g>0).sum():.1f}% of truth) ", "; ".join(f"{k} {100*(mk&weak).sum()/n:.1f}" for k, mk in masks.items()))
    if v.index == V:
        # regions that hold the weak pixels: region id -> weak pixel count, size, planes
        ids, cnt = np.unique(region[weak], return_counts=True)
        for i, c in zip(ids, cnt):
            planes = [p for p in r["planes"] if p["region"] == i]
            print(f"   region {i}: {c} weak px, points {r['sizes'][i-1] if i>0 else '-'}, planes {[ (len(p['inliers'])) for p in planes]}")
        fig, ax = plt.subplots(2, 2, figsize=(11, 8))
        ax[0,0].imshow(v.image()); ax[0,0].set_title("image")
        ax[0,1].imshow(np.where(weak, region, -1), cmap="tab20"); ax[0,1].set_title("region on weak px")
        cls = np.full(weak.shape, -1)
        for k, mk in enumerate(masks.values()): cls[mk & weak] = k
        ax[1,0].imshow(cls, cmap="tab10", vmin=-1, vmax=9); ax[1,0].set_title("class " + ",".join(f"{k}:{n[:12]}" for k, n in enumerate(masks)), fontsize=7)
        pts = mesh["points"]; ax[1,1].imshow(np.where(g > 0, g, np.nan)); ax[1,1].scatter(pts[:,0], pts[:,1], s=1, c="r"); ax[1,1].set_title("truth + support points")
        fig.savefig(f"/tmp/s25/bimodal/view{V}_seed{seed}.png", dpi=70)
