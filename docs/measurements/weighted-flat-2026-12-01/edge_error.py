"""Where a run's weak-texture errors lie: the share of the weak pixels within 2% of the truth,
by their distance (Chebyshev, px, at the map's size) to the nearest occluding edge: a pixel
whose truth is below 95% of theirs (a nearer surface). RUN is `mvscope run`'s output, SCENE
the scene with gt/%08d.pfm and gt/%08d_lowtex.png."""
import sys, pathlib
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

def read_pfm(p):
    with open(p, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        a = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4")
    c = 3 if kind == b"PF" else 1
    return np.flipud(a.reshape(h, w, c)[..., 0] if c == 3 else a.reshape(h, w)).astype(np.float64)

def resample(a, h, w):
    sh, sw = a.shape
    u = np.clip(np.round((np.arange(w) + 0.5) * sw / w - 0.5), 0, sw - 1).astype(int)
    v = np.clip(np.round((np.arange(h) + 0.5) * sh / h - 0.5), 0, sh - 1).astype(int)
    return a[np.ix_(v, u)]

run, scene = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
R = 10
bins = [(1, 1), (2, 5), (6, 10), (11, 10**9)]
tot = {b: [0, 0] for b in bins}; tot_all = [0, 0]; err_mass = {b: 0 for b in bins}
for dpath in sorted((run / "depth").glob("*.pfm")):
    d = read_pfm(dpath)
    h, w = d.shape
    gt = resample(read_pfm(scene / "gt" / dpath.name), h, w)
    weak = resample(plt.imread(scene / "gt" / dpath.name.replace(".pfm", "_lowtex.png")) > 0, h, w)
    valid = gt > 0
    dist = np.full((h, w), 10**9)
    pad = np.pad(gt, R, constant_values=0)
    for r in range(R, 0, -1):
        near = np.zeros((h, w), bool)
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                if max(abs(dx), abs(dy)) != r:
                    continue
                s = pad[R + dy:R + dy + h, R + dx:R + dx + w]
                near |= (s > 0) & (s < 0.95 * gt)
        dist[near] = r  # smaller r overwrite
    ok = (d > 0) & (np.abs(d - gt) <= 0.02 * gt)
    m = weak & valid
    tot_all[0] += ok[m].sum(); tot_all[1] += m.sum()
    for b in bins:
        sel = m & (dist >= b[0]) & (dist <= b[1])
        tot[b][0] += ok[sel].sum(); tot[b][1] += sel.sum()
        err_mass[b] += (~ok[sel]).sum()
n_err = tot_all[1] - tot_all[0]
print(f"{run.name}: weak pixels within 2% {100*tot_all[0]/tot_all[1]:.1f}% of {tot_all[1]}")
for b in bins:
    lab = f"{b[0]}-{b[1]} px" if b[1] < 10**9 else f"over {b[0]-1} px"
    c, n = tot[b]
    print(f"  {lab:>10s} from a nearer surface: {100*n/tot_all[1]:5.1f}% of the weak pixels, "
          f"{100*c/max(n,1):5.1f}% within 2%, {100*err_mass[b]/max(n_err,1):5.1f}% of the weak errors")
