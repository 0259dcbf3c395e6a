# Where does view 3's block of wrong support points (left wall, lower left) come from? Median est/gt
# over the block and over the upper left wall after every step, Regions vs ACMM, seed 0, 320.
import warnings, numpy as np, mvscope, sys
import os; I = os.environ.get('SCENE', '/work/shared/data/rgbd/icl-livingroom')
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(I, max_image_size=320)
gt = mvscope.read_pfm(f'{I}/gt/00000003.pfm')
def stats(dep, x0, x1, y0, y1):
    H, W = dep.shape
    ys, xs = np.mgrid[0:H, 0:W]
    sel = (xs >= x0 * W / 320) & (xs < x1 * W / 320) & (ys >= y0 * H / 240) & (ys < y1 * H / 240)
    g = gt[np.clip(((ys + 0.5) * gt.shape[0] / H).astype(int), 0, gt.shape[0]-1), np.clip(((xs + 0.5) * gt.shape[1] / W).astype(int), 0, gt.shape[1]-1)]
    ok = sel & (g > 0) & (dep > 0)
    r = dep[ok] / g[ok] - 1
    return f"{np.median(r):+.3f} ({np.mean(np.abs(r) <= 0.02):.2f})"
for method in sys.argv[1:]:
    s = mvscope.Session(scene, method=method, seed=0)
    for st in s.steps:
        s.goto(st["index"] + 1)
        mp = s.maps(3)
        if mp is None or mp.get("depth") is None:
            continue
        dep = np.asarray(mp["depth"])
        line = f"{method} step {st['index']:3d} L{st['level']} {st['stage']:<22} block {stats(dep, 5, 100, 115, 235)}  upper-left {stats(dep, 5, 160, 20, 110)}  right wall {stats(dep, 180, 300, 60, 170)}  ceiling {stats(dep, 100, 300, 0, 45)}"
        if "prior_depth" in mp and mp["prior_depth"] is not None and np.asarray(mp["prior_depth"]).size > 1:
            pd_ = np.asarray(mp["prior_depth"])
            if (pd_ > 0).any(): line += f"  prior block {stats(pd_, 5, 100, 115, 235)} right {stats(pd_, 180, 300, 60, 170)}"
        print(line, flush=True)
