# Each region plane of the finest prior, per view: the pixels it paints, the weak ones, and
# how many of them its prior depth puts within 2% of the truth. Usage: planes.py SCENE [NAME=VALUE...]
import sys, pathlib, warnings, numpy as np, matplotlib
matplotlib.use("Agg"); import matplotlib.pyplot as plt
import mvscope
room = pathlib.Path(sys.argv[1]); sets = sys.argv[2:]
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
def resized(path, shape):
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0]), 0, a.shape[0] - 1)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1]), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
s = mvscope.Session(scene, method="regions", seed=0, params={k: v for k, v in (a.split("=") for a in sets)})
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
print("settings:", " ".join(sets) or "Regions' defaults")
for v in scene.views:
    m, mesh = s.maps(v.index), s.prior_mesh(v.index)
    gt = resized(room / "gt" / f"{v.scene_index:08d}.pfm", (m.height, m.width))
    weak = resized(room / "gt" / f"{v.scene_index:08d}_lowtex.png", (m.height, m.width)) & (gt > 0)
    r = mesh["regions"]
    rows, cols = np.arange(m.height)[:, None] // r["cell"], np.arange(m.width) // r["cell"]
    plane = r["plane"][rows, cols]
    prior = m["prior_depth"]
    right = (prior > 0) & (gt > 0) & (np.abs(prior - gt) <= 0.02 * gt)
    print(f"view {v.index}: {len(r['planes'])} planes; weak pixels {int(weak.sum())}, "
          f"painted by a plane {int((weak & (plane >= 0)).sum())}, right there {int((weak & (plane >= 0) & right).sum())}")
    for k in range(len(r["planes"])):
        p = plane == k
        if p.sum() == 0: continue
        ys, xs = np.nonzero(p)
        print(f"   plane {k}: region {r['planes'][k]['region']}, inliers {len(r['planes'][k]['inliers'])}, "
              f"x {xs.min()}-{xs.max()} y {ys.min()}-{ys.max()}, pixels {int(p.sum())} ({int((p & right).sum())} right), "
              f"weak {int((p & weak).sum())} ({int((p & weak & right).sum())} right)")
