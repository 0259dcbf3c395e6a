"""Regions on the synthetic scene, with and without prior_flat_weighted: at the end of the
finest scale's prior stage, per view: flat cells, regions, planes and their inliers, weak
pixels with a prior right / wrong / none, and why none."""
import sys, pathlib, warnings
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene_dir = pathlib.Path(sys.argv[1]); views = [int(v) for v in sys.argv[2].split(",")]
scene = mvscope.Scene.open(scene_dir, max_image_size=320)
def resized(path, shape):
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    rows = np.clip(np.round((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0] - 0.5), 0, a.shape[0] - 1)
    cols = np.clip(np.round((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1] - 0.5), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
for weighted in [False, True]:
    s = mvscope.Session(scene, method="regions", seed=0, params={"prior_flat_weighted": weighted})
    last = s.num_levels - 1
    s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
    for v in views:
        mesh, m = s.prior_mesh(v), s.maps(v)
        r = mesh["regions"]
        gt = resized(scene_dir / "gt" / f"{v:08d}.pfm", (m.height, m.width))
        weak = resized(scene_dir / "gt" / f"{v:08d}_lowtex.png", (m.height, m.width)) & (gt > 0)
        cells = r["region"][np.arange(m.height)[:, None] // r["cell"], np.arange(m.width) // r["cell"]]
        pd = m["prior_depth"]
        right = (pd > 0) & (np.abs(pd - gt) <= 0.02 * gt)
        wrong = (pd > 0) & ~right
        sizes = r["sizes"]
        planes = r["planes"]
        print(f"weighted={weighted} view {v}: flat cells {np.sum(r['region'] > 0)}, regions {len(sizes)} "
              f"(largest {sorted(sizes, reverse=True)[:4]}), planes {[len(p['inliers']) if isinstance(p, dict) else p for p in planes][:6]}; "
              f"weak: prior right {100*np.mean(right[weak]):.1f}, wrong {100*np.mean(wrong[weak]):.1f}, "
              f"none {100*np.mean(pd[weak] <= 0):.1f} (flat without a plane {100*np.mean(((pd <= 0) & (cells > 0))[weak]):.1f})", flush=True)
