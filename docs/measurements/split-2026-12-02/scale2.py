"""Shipped ICL, 320, seed 0, Regions: the middle scale's prior (level 1, end of its planar
prior stage), where `--stages` puts the first loss of prior_flat_weighted. Per view, with
the weighted test off / on: the weak pixels the prior covers and how many are right within
2%, split by what painted them (a region's plane or a triangle), and the regions' planes."""
import sys, pathlib, warnings
import numpy as np
import matplotlib; matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope
warnings.simplefilter("ignore", mvscope.SceneWarning)
d = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "/work/shared/data/rgbd/icl-livingroom")
level = int(sys.argv[2]) if len(sys.argv) > 2 else 1
scene = mvscope.Scene.open(d, max_image_size=320)
def resized(path, shape):
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    if a.ndim == 3: a = a[..., 0]
    rows = np.clip(np.round((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0] - 0.5), 0, a.shape[0] - 1)
    cols = np.clip(np.round((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1] - 0.5), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
for w in (False, True):
    s = mvscope.Session(scene, method="regions", seed=0, params={"prior_flat_weighted": w})
    s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (level, "planar prior")) + 1)
    tot = np.zeros(4)
    for v in range(len(scene.views)):
        mesh, m = s.prior_mesh(v), s.maps(v)
        gt = resized(d / "gt" / f"{v:08d}.pfm", (m.height, m.width))
        weak = resized(d / "gt" / f"{v:08d}_lowtex.png", (m.height, m.width)) & (gt > 0)
        pd = np.asarray(m["prior_depth"]); dep = np.asarray(m["depth"])
        r = mesh["regions"]; c = r["cell"]
        ys, xs = np.arange(m.height)[:, None] // c, np.arange(m.width)[None, :] // c
        reg = r["region"][ys, xs]; pl = r["plane"][ys, xs]
        by_region = (pl >= 0) & (pd > 0)
        by_tri = (pl < 0) & (pd > 0)
        right = np.abs(pd - gt) <= 0.02 * gt
        fin = np.abs(dep - gt) <= 0.02 * gt
        sizes = sorted(((len(q["inliers"]), q["region"]) for q in r["planes"]), reverse=True)[:3]
        nreg = int(np.sum(np.array(r["sizes"]) > 0))
        print(f"weighted={w!s:5} view {v}: weak {weak.sum()}: region plane {100*np.mean(by_region[weak]):.1f}% "
              f"({100*np.mean(right[weak & by_region]) if np.any(weak & by_region) else 0:.1f}% right), "
              f"triangles {100*np.mean(by_tri[weak]):.1f}% ({100*np.mean(right[weak & by_tri]) if np.any(weak & by_tri) else 0:.1f}% right), "
              f"flat cells without a plane {100*np.mean(((reg > 0) & (pl < 0))[weak]):.1f}%; after the stage {100*np.mean(fin[weak]):.1f}% right; "
              f"{nreg} regions with points, {len(r['planes'])} planes, largest (inliers, region) {sizes}", flush=True)
        tot += [weak.sum(), (weak & by_region).sum(), (weak & by_region & right).sum(), (weak & fin).sum()]
    print(f"weighted={w}: all views: region plane on {100*tot[1]/tot[0]:.1f}% of the weak pixels, right on {100*tot[2]/max(tot[1],1):.1f}% of those; after the stage {100*tot[3]/tot[0]:.1f}% right")
