"""Weak pixels whose state (within 2%) differs between two runs: where they lie."""
import sys, pathlib
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
sys.path.insert(0, "/work/main/docs/measurements/weighted-flat-2026-12-01")
exec(open("/work/main/docs/measurements/weighted-flat-2026-12-01/edge_error.py").read().split("run, scene =")[0])
a, b, scene = map(pathlib.Path, sys.argv[1:4])
for dpath in sorted((a / "depth").glob("*.pfm")):
    da, db = read_pfm(dpath), read_pfm(b / "depth" / dpath.name)
    h, w = da.shape
    gt = resample(read_pfm(scene / "gt" / dpath.name), h, w)
    weak = resample(plt.imread(scene / "gt" / dpath.name.replace(".pfm", "_lowtex.png")) > 0, h, w) & (gt > 0)
    oka = (np.abs(da - gt) <= 0.02 * gt); okb = (np.abs(db - gt) <= 0.02 * gt)
    lost = weak & oka & ~okb; won = weak & ~oka & okb
    print(dpath.name, "weak", weak.sum(), "lost", lost.sum(), "won", won.sum())
    for name, m in (("lost", lost), ("won", won)):
        if m.sum():
            ys, xs = np.nonzero(m)
            # coarse histogram over 40 px tiles
            tiles = {}
            for y, x in zip(ys, xs):
                tiles[(x // 40, y // 40)] = tiles.get((x // 40, y // 40), 0) + 1
            top = sorted(tiles.items(), key=lambda t: -t[1])[:6]
            print(" ", name, "by 40px tile (x0,y0):", [((tx*40, ty*40), n) for (tx, ty), n in top])
            rel = (db[m] - gt[m]) / gt[m] if name == "lost" else (da[m] - gt[m]) / gt[m]
            print("   its error in the worse run: median %.3f, p10 %.3f, p90 %.3f" % (np.median(rel), np.percentile(rel, 10), np.percentile(rel, 90)))
