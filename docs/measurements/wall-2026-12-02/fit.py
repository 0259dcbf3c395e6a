"""Reads dump.py's .npz. Each view's largest flat region: are its support points' errors
against the truth's plane centred (noise a fit over many points would average out) or one
way (a bias no fit removes)? And a plane fitted to all of them by least absolute deviations
in 1/d (the fit RANSAC's 1% consensus cannot make): how much of the region's truth does it
hold within 2%, against the points' own share?"""
import sys
import numpy as np
from wallfit import lad

z = np.load(sys.argv[1] if len(sys.argv) > 1 else "/tmp/wall-dump.npz")  # dump.py's output




rows = []
for v in range(int(z["views"])):
    g = lambda k: z[f"{v}_{k}"]
    gt, reg, c, K = g("gt"), g("region"), int(g("cell")), g("K")
    big = int(np.argmax(g("sizes"))) + 1
    h, w = gt.shape
    ys, xs = np.mgrid[0:h, 0:w]
    nu = lambda x: (x - K[0, 2]) / K[0, 0]; nv = lambda y: (y - K[1, 2]) / K[1, 1]
    inreg = (reg[ys // c, xs // c] == big) & (gt > 0)
    A = np.stack([nu(xs[inreg]), nv(ys[inreg]), np.ones(inreg.sum())], 1)
    tp, *_ = np.linalg.lstsq(A, 1 / gt[inreg], rcond=None)
    p, dep = g("points"), g("point_depth")
    pin = (reg[p[:, 1] // c, p[:, 0] // c] == big) & (dep > 0)
    P = np.stack([nu(p[pin, 0]), nv(p[pin, 1]), np.ones(pin.sum())], 1)
    on_truth = 1 / (P @ tp)
    err = dep[pin] / on_truth - 1  # signed: + deeper than the truth's plane
    fit = lad(P, 1 / dep[pin])
    fd = 1 / (A @ fit)
    held = np.mean(np.abs(fd - gt[inreg]) <= 0.02 * gt[inreg])
    tp_held = np.mean(np.abs(1 / (A @ tp) - gt[inreg]) <= 0.02 * gt[inreg])
    est = g("depth")[inreg]
    final = np.mean((est > 0) & (np.abs(est - gt[inreg]) <= 0.02 * gt[inreg]))
    rows.append((np.median(err), np.mean(err > 0), np.percentile(err, 25), np.percentile(err, 75), held, tp_held, final))
    print(f"view {v}: {pin.sum()} points; error to the truth's plane median {100*np.median(err):+.1f}%, "
          f"deeper {100*np.mean(err>0):.0f}%, quartiles {100*np.percentile(err,25):+.1f}/{100*np.percentile(err,75):+.1f}%; "
          f"LAD plane holds the region's truth within 2% on {100*held:.0f}% (truth's own plane {100*tp_held:.0f}%; the map there now {100*final:.0f}%)")
a = np.array(rows)
print(f"mean: median error {100*a[:,0].mean():+.1f}%, LAD plane {100*a[:,4].mean():.1f}%, truth's plane {100*a[:,5].mean():.1f}%, map {100*a[:,6].mean():.1f}%")

# What painting each view's largest region with that fit would change, view-wide: the
# region's pixels take the plane's depth, every other pixel keeps the map's (the map as it
# stands after the finest prior stage, so an upper bound on what a later pass would keep).
tot = {"map2": 0, "lad2": 0, "map5": 0, "lad5": 0, "wmap2": 0, "wlad2": 0, "n": 0, "wn": 0}
for v in range(int(z["views"])):
    g = lambda k: z[f"{v}_{k}"]
    gt, reg, c, K, weak = g("gt"), g("region"), int(g("cell")), g("K"), g("weak")
    big = int(np.argmax(g("sizes"))) + 1
    h, w = gt.shape
    ys, xs = np.mgrid[0:h, 0:w]
    nu = lambda x: (x - K[0, 2]) / K[0, 0]; nv = lambda y: (y - K[1, 2]) / K[1, 1]
    inr = reg[ys // c, xs // c] == big
    p, dep = g("points"), g("point_depth")
    pin = (reg[p[:, 1] // c, p[:, 0] // c] == big) & (dep > 0)
    P = np.stack([nu(p[pin, 0]), nv(p[pin, 1]), np.ones(pin.sum())], 1)
    fit = lad(P, 1 / dep[pin])
    painted = g("depth").copy()
    inv = fit[0] * nu(xs) + fit[1] * nv(ys) + fit[2]
    painted[inr] = np.where(inv[inr] > 0, 1 / np.maximum(inv[inr], 1e-9), 0)
    ok = gt > 0
    within = lambda e, t, m: np.sum(m & (e > 0) & (np.abs(e - gt) <= t * gt))
    tot["map2"] += within(g("depth"), 0.02, ok); tot["lad2"] += within(painted, 0.02, ok)
    tot["map5"] += within(g("depth"), 0.05, ok); tot["lad5"] += within(painted, 0.05, ok)
    tot["wmap2"] += within(g("depth"), 0.02, ok & weak); tot["wlad2"] += within(painted, 0.02, ok & weak)
    tot["n"] += ok.sum(); tot["wn"] += (ok & weak).sum()
print(f"kitchen-a at the end of the finest prior stage, all pixels within 2%: map {100*tot['map2']/tot['n']:.1f}, "
      f"largest regions painted with their LAD plane {100*tot['lad2']/tot['n']:.1f}; within 5% {100*tot['map5']/tot['n']:.1f} -> "
      f"{100*tot['lad5']/tot['n']:.1f}; weak texture within 2% {100*tot['wmap2']/tot['wn']:.1f} -> {100*tot['wlad2']/tot['wn']:.1f}")
