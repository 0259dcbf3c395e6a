"""Per view, at the end of the finest scale's prior stage: flat cells, regions, planes, and the
weak pixels whose prior is right / wrong / none (flat without a plane), under settings."""
import sys, pathlib, warnings, json
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene_dir = pathlib.Path(sys.argv[1])
settings = [json.loads(a) for a in sys.argv[2:]]
scene = mvscope.Scene.open(scene_dir, max_image_size=320)
def resized(path, shape):
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    rows = np.clip(np.round((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0] - 0.5), 0, a.shape[0] - 1)
    cols = np.clip(np.round((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1] - 0.5), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
for sets in settings:
    s = mvscope.Session(scene, method="regions", seed=0, params=sets)
    last = s.num_levels - 1
    s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
    for v in range(len(scene.views)):
        mesh, m = s.prior_mesh(v), s.maps(v)
        r = mesh["regions"]
        gt = resized(scene_dir / "gt" / f"{v:08d}.pfm", (m.height, m.width))
        weak = resized(scene_dir / "gt" / f"{v:08d}_lowtex.png", (m.height, m.width)) & (gt > 0)
        c = r["cell"]
        cells = r["region"][np.arange(m.height)[:, None] // c, np.arange(m.width) // c]
        painted = r["plane"][np.arange(m.height)[:, None] // c, np.arange(m.width) // c] >= 0
        pd = m["prior_depth"]
        right = (pd > 0) & (np.abs(pd - gt) <= 0.02 * gt)
        wrong = (pd > 0) & ~right
        est = m["depth"]
        print(f"{sets} view {v}: flat cells {np.sum(r['region'] > 0)}, regions {len(r['sizes'])} "
              f"(largest {sorted(r['sizes'], reverse=True)[:3]}), planes {[len(p['inliers']) for p in r['planes']][:6]}; "
              f"weak: region-painted {100*np.mean(painted[weak]):.1f} (right {100*np.mean((right & painted)[weak]):.1f}), "
              f"prior right {100*np.mean(right[weak]):.1f}, wrong {100*np.mean(wrong[weak]):.1f}, none {100*np.mean(pd[weak] <= 0):.1f}; "
              f"depth now within 2% {100*np.mean((np.abs(est - gt) <= 0.02 * gt)[weak]):.1f}", flush=True)
