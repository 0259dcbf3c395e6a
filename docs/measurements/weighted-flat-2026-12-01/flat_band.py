"""Which weak pixels near an edge have a flat window (std < 3 grey levels around the window's
least-squares ramp, every pixel of the 11 x 11 window: Regions' flat test, window_spread with
prior_flat_ramp), by distance to the nearer surface. Grey from the images as mvscope reads them
is approximated by Rec. 601 luma."""
import sys, pathlib
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
exec(open(pathlib.Path(__file__).with_name("edge_error.py")).read().split("run, scene =")[0])
scene = pathlib.Path(sys.argv[1]); run = pathlib.Path(sys.argv[2])
R = 5
tab = {}
for dpath in sorted((run / "depth").glob("*.pfm")):
    d = read_pfm(dpath); h, w = d.shape
    img = plt.imread(next((scene / "images").glob(dpath.stem + ".*"))).astype(np.float64)
    if img.max() <= 1.0: img = img * 255
    g = img[..., 0] * 0.299 + img[..., 1] * 0.587 + img[..., 2] * 0.114 if img.ndim == 3 else img
    g = resample(g, h, w)
    gt = resample(read_pfm(scene / "gt" / dpath.name), h, w)
    weak = resample(plt.imread(scene / "gt" / dpath.name.replace(".pfm", "_lowtex.png")) > 0, h, w) & (gt > 0)
    ok = (d > 0) & (np.abs(d - gt) <= 0.02 * gt)
    for y in range(R, h - R, 2):
        for x in range(R, w - R, 2):
            if not weak[y, x]:
                continue
            blk = gt[y - 10:y + 11, x - 10:x + 11] if y >= 10 and x >= 10 else gt[max(y-10,0):y+11, max(x-10,0):x+11]
            dist = 99
            for r in range(1, 11):
                b = gt[max(y - r, 0):y + r + 1, max(x - r, 0):x + r + 1]
                if ((b > 0) & (b < 0.95 * gt[y, x])).any():
                    dist = r; break
            band = "1" if dist == 1 else "2-5" if dist <= 5 else "6-10" if dist <= 10 else ">10"
            win = g[y - R:y + R + 1, x - R:x + R + 1]
            yy, xx = np.mgrid[-R:R + 1, -R:R + 1]
            A = np.stack([xx.ravel(), yy.ravel(), np.ones(xx.size)], 1)
            res = win.ravel() - A @ np.linalg.lstsq(A, win.ravel(), rcond=None)[0]
            flat = res.std() < 3.0
            t = tab.setdefault(band, [0, 0, 0, 0])
            t[0] += 1; t[1] += flat; t[2] += ok[y, x]; t[3] += ok[y, x] and flat
for band in ["1", "2-5", "6-10", ">10"]:
    n, f, o, of = tab.get(band, [0, 0, 0, 0])
    print(f"{run.name} {band:>5s} px: {n} weak px (every 2nd row and column), flat window {100*f/max(n,1):.1f}%, "
          f"within 2% {100*o/max(n,1):.1f}% (flat ones {100*of/max(f,1):.1f}%, the others {100*(o-of)/max(n-f,1):.1f}%)")
