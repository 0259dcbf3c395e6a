"""Shipped ICL, 320, seed 0: the finest prior stage's support points with prior_flat_weighted off / on
(edge rule on in both): how many, how right, and which cells changed their point."""
import sys, pathlib, warnings
import numpy as np
import matplotlib; matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope
warnings.simplefilter("ignore", mvscope.SceneWarning)
d = pathlib.Path("/work/shared/data/rgbd/icl-livingroom")
scene = mvscope.Scene.open(d, max_image_size=320)
def resized(path, shape):
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    rows = np.clip(np.round((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0] - 0.5), 0, a.shape[0] - 1)
    cols = np.clip(np.round((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1] - 0.5), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
views = [int(v) for v in sys.argv[1:]] or [1, 4]
out = {}
for w in (False, True):
    s = mvscope.Session(scene, method="regions", seed=0, params={"prior_flat_weighted": w, "prior_region_edge": True})
    last = s.num_levels - 1
    s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
    for v in views:
        mesh, m = s.prior_mesh(v), s.maps(v)
        gt = resized(d / "gt" / f"{v:08d}.pfm", (m.height, m.width))
        p = mesh["points"]; dep = mesh["point_depth"]
        g = gt[p[:, 1], p[:, 0]]
        ok = (g > 0) & (np.abs(dep - g) <= 0.02 * g)
        r = mesh["regions"]; c = r["cell"]
        reg = r["region"][p[:, 1] // c, p[:, 0] // c]
        big = np.bincount(reg[reg > 0]).argmax() if np.any(reg > 0) else 0
        inb = reg == big
        out[(w, v)] = {tuple(q) for q in p}
        print(f"weighted={w} view {v}: {len(p)} points, {100*ok.mean():.1f}% within 2%; flat-region points {np.sum(reg>0)} "
              f"({100*ok[reg>0].mean():.1f}% right); largest region {big}: {inb.sum()} points, {100*ok[inb].mean():.1f}% right; "
              f"planes {[len(q['inliers']) for q in r['planes'] if q['region'] + 1 == big][:4]}; cost median {np.median(mesh['point_cost'][inb]):.3f}", flush=True)
        # the truth's plane through the largest region's points: how many would it hold at 1%?
        if inb.sum() >= 3:
            k = np.array(scene.views[v].K) * (m.width / scene.views[v].width)
            u = (p[inb, 0] - k[0, 2]) / k[0, 0]; vv = (p[inb, 1] - k[1, 2]) / k[1, 1]
            A = np.stack([u, vv, np.ones_like(u)], 1)
            gi = g[inb]
            good = gi > 0
            abc, *_ = np.linalg.lstsq(A[good], 1 / gi[good], rcond=None)
            pd = 1 / (A @ abc)
            print(f"   truth's plane over that region's pixels: its depth within 1% of the truth at {100*np.mean(np.abs(pd[good]-gi[good]) <= 0.01*gi[good]):.1f}% of them; "
                  f"the points within 1% of it {100*np.mean(np.abs(pd - dep[inb]) <= 0.01*pd):.1f}%", flush=True)
for v in views:
    a, b = out[(False, v)], out[(True, v)]
    print(f"view {v}: points in both {len(a & b)}, only off {len(a - b)}, only weighted {len(b - a)}")
