"""Offline: Regions' flat test (std < 3 around the least-squares ramp over every pixel of the
11 x 11 window) against the same test on the window as the adaptive matching cost weighs it
(the 36 samples, Gaussian spatial sigma 5, colour sigma max(3, 1.4826 x lower median |dI|),
weighted least-squares ramp). Weak pixels by distance to a nearer surface, and textured pixels."""
import sys, pathlib
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
exec(open(pathlib.Path(__file__).with_name("edge_error.py")).read().split("run, scene =")[0])
scene = pathlib.Path(sys.argv[1]); run = pathlib.Path(sys.argv[2])
R = 5
offs = np.arange(-5, 6, 2)
SX, SY = np.meshgrid(offs, offs)
yy, xx = np.mgrid[-R:R + 1, -R:R + 1]
A_all = np.stack([xx.ravel(), yy.ravel(), np.ones(xx.size)], 1)
A_s = np.stack([SX.ravel(), SY.ravel(), np.ones(36)], 1).astype(float)
sp = (SX**2 + SY**2).ravel() / 50.0
tab = {}
for dpath in sorted((run / "depth").glob("*.pfm")):
    d = read_pfm(dpath); h, w = d.shape
    img = plt.imread(next((scene / "images").glob(dpath.stem + ".*"))).astype(np.float64)
    if img.max() <= 1.0: img = img * 255
    g = img[..., 0] * 0.299 + img[..., 1] * 0.587 + img[..., 2] * 0.114 if img.ndim == 3 else img
    g = resample(g, h, w)
    gt = resample(read_pfm(scene / "gt" / dpath.name), h, w)
    lw = resample(plt.imread(scene / "gt" / dpath.name.replace(".pfm", "_lowtex.png")) > 0, h, w)
    ok = (d > 0) & (np.abs(d - gt) <= 0.02 * gt)
    for y in range(R, h - R, 3):
        for x in range(R, w - R, 3):
            if gt[y, x] <= 0:
                continue
            dist = 99
            for r in range(1, 11):
                b = gt[max(y - r, 0):y + r + 1, max(x - r, 0):x + r + 1]
                if ((b > 0) & (b < 0.95 * gt[y, x])).any():
                    dist = r; break
            if lw[y, x]:
                band = "weak 1" if dist == 1 else "weak 2-5" if dist <= 5 else "weak 6-10" if dist <= 10 else "weak >10"
            else:
                band = "textured"
            win = g[y - R:y + R + 1, x - R:x + R + 1].ravel()
            res = win - A_all @ np.linalg.lstsq(A_all, win, rcond=None)[0]
            flat0 = res.std() < 3.0
            v = g[np.ix_(y + offs, x + offs)].ravel() - g[y, x]
            a = np.sort(np.abs(v))[17]
            sig = max(3.0, 1.4826 * a)
            e = sp + v**2 / (2 * sig**2)
            wt = np.exp(e.min() - e)
            sw = np.sqrt(wt)
            coef = np.linalg.lstsq(A_s * sw[:, None], v * sw, rcond=None)[0]
            r2 = v - A_s @ coef
            flat1 = np.sqrt((wt * r2**2).sum() / wt.sum()) < 3.0
            t = tab.setdefault(band, [0, 0, 0, 0, 0])
            t[0] += 1; t[1] += flat0; t[2] += flat1; t[3] += ok[y, x]; t[4] += ok[y, x] and flat1 and not flat0
for band in ["weak 1", "weak 2-5", "weak 6-10", "weak >10", "textured"]:
    n, f0, f1, o, o1 = tab.get(band, [0] * 5)
    print(f"{run.name} {band:>9s}: {n} px; flat every pixel {100*f0/max(n,1):5.1f}%, flat as weighed {100*f1/max(n,1):5.1f}%; "
          f"within 2% now {100*o/max(n,1):5.1f}%")
