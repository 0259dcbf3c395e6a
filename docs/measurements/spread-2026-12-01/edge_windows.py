"""Why the adaptive bilateral weight still lets a nearer surface decide some weak windows
beside it (docs/accuracy.md, "Where the adaptive weight still fattens"). On view 0 at SIZE,
for N random weak pixels (the truth's weak-texture mask) whose 11 x 11 window holds a sample on
a nearer surface (truth below 95% of the centre's depth), and N textured pixels with no such
sample: the nearer surface's share of the window's weighted variance, which the NCC matches,
split by the samples' colour distance to the centre and by the centre's distance to the edge;
and the same under two other robust colour scales computed here from the grey image (checked
against the inspector's sigma for the adaptive kernel)."""
import sys, pathlib, warnings
from statistics import NormalDist
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope

scene_dir = pathlib.Path(sys.argv[1]); size = int(sys.argv[2]); n_pix = int(sys.argv[3])
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(scene_dir, max_image_size=size)

def resized(path, shape):
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0]), 0, a.shape[0] - 1)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1]), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]

SIGMA_S, SIGMA_C = 5.0, 3.0
offs = np.arange(-5, 6, 2)
s = mvscope.Session(scene, method="acmh", seed=0, params={"bilateral_kernel": "adaptive"})
first = next(st["index"] for st in s.steps if st["view"] == 0 and st.get("half") == "red")
s.goto(first + 1)
m = s.maps(0)
gt = resized(scene_dir / "gt" / "00000000.pfm", (m.height, m.width))
weak = resized(scene_dir / "gt" / "00000000_lowtex.png", (m.height, m.width)) & (gt > 0)
g = np.asarray(scene.views[0].gray(), dtype=np.float64)
h, w = gt.shape
edge, tex = [], []
for y in range(5, h - 5):
    for x in range(5, w - 5):
        if (x + y) % 2 or gt[y, x] <= 0:
            continue
        win = gt[np.ix_(y + offs, x + offs)]
        near = (win > 0) & (win < 0.95 * gt[y, x])
        if weak[y, x] and near.any():
            edge.append((x, y, near))
        elif not weak[y, x] and not near.any():
            tex.append((x, y, None))
rng = np.random.default_rng(0)
pe = [edge[i] for i in rng.choice(len(edge), min(n_pix, len(edge)), replace=False)]
pt = [tex[i] for i in rng.choice(len(tex), min(n_pix, len(tex)), replace=False)]

X, Y = np.meshgrid(offs, offs)
spatial = (X**2 + Y**2) / (2 * SIGMA_S**2)
def window(x, y):
    return g[np.ix_(y + offs, x + offs)]
def share(x, y, sigma):
    """Gaussian weights with colour sigma, and each sample's share of the weighted variance."""
    I = window(x, y)
    e = -spatial - (I - g[y, x]) ** 2 / (2 * sigma**2)
    wt = np.exp(e - e.max())
    mu = (wt * I).sum() / wt.sum()
    v = wt * (I - mu) ** 2
    return v / max(v.sum(), 1e-300), wt
def sigma_quantile(x, y, q):
    """max(sigma_c, the q-quantile of |dI| / that of |N(0, 1)|): q = 0.5 is mvscope's adaptive
    sigma (1.4826 x the lower median)."""
    d = np.sort(np.abs(window(x, y) - g[y, x]).ravel())
    return max(SIGMA_C, d[max(int(np.ceil(q * d.size)) - 1, 0)] / NormalDist().inv_cdf(0.5 + q / 2))
def sigma_about_median(x, y):
    """sqrt(2) x 1.4826 x the median |I - median(I)|: the spread of a difference of two samples
    of the window, blind to how far the centre itself is off its surface."""
    I = np.sort(window(x, y).ravel())
    med = I[(I.size - 1) // 2]
    return max(SIGMA_C, 2**0.5 * 1.4826 * np.sort(np.abs(I - med))[(I.size - 1) // 2])
def edge_distance(x, y):
    for r in range(1, 6):
        blk = gt[max(y - r, 0):y + r + 1, max(x - r, 0):x + r + 1]
        if ((blk > 0) & (blk < 0.95 * gt[y, x])).any():
            return r
    return 6

gap = max(abs(s.inspect(0, int(x), int(y))["window"]["sigma"] - sigma_quantile(x, y, 0.5))
          for x, y, _ in pe[:20])
print(f"{scene_dir.name}: {len(pe)} of {len(edge)} weak pixels beside a nearer surface, {len(pt)} textured; "
      f"the adaptive sigma here against the inspector's: largest difference {gap:.1e}")
scales = [("Gaussian, sigma_c = 3", lambda x, y: SIGMA_C),
          ("adaptive (mvscope, median |dI|)", lambda x, y: sigma_quantile(x, y, 0.5)),
          ("quarter quantile of |dI|", lambda x, y: sigma_quantile(x, y, 0.25)),
          ("sqrt2 x MAD about the window's median", sigma_about_median)]
dist = np.array([edge_distance(x, y) for x, y, _ in pe])
for name, sg in scales:
    held = np.array([share(x, y, sg(x, y))[0][near].sum() for x, y, near in pe])
    eff = [(lambda wt: wt.sum() ** 2 / (wt**2).sum())(share(x, y, sg(x, y))[1]) for x, y, _ in pt]
    over = held > 0.5
    print(f"  {name:38s}: nearer share {100*held.mean():5.1f}%, over half in {100*over.mean():4.1f}% "
          f"(1 px from the edge: {np.sum(over & (dist == 1))} of {np.sum(dist == 1)}, "
          f"2-5 px: {np.sum(over & (dist > 1))} of {np.sum(dist > 1)}); textured: "
          f"median (sum w)^2/sum w^2 {np.median(eff):.1f} of 36")

# Under the adaptive sigma, the windows the nearer surface decides: by the colour distance of
# its samples to the centre, and whether the centre is off its own surface's grey.
bins = [0, 1, 2, 3, np.inf]
tot = np.zeros(4); cnt = np.zeros(4); n = 0; off = 0; sig = []
for x, y, near in pe:
    sg = sigma_quantile(x, y, 0.5)
    sh, _ = share(x, y, sg)
    if sh[near].sum() <= 0.5:
        continue
    n += 1; sig.append(sg)
    d = np.abs(window(x, y) - g[y, x]) / sg
    for i in range(4):
        sel = near & (d >= bins[i]) & (d < bins[i + 1])
        tot[i] += sh[sel].sum(); cnt[i] += sel.sum()
    off += np.median(np.abs(window(x, y)[~near] - g[y, x])) > SIGMA_C
print(f"  adaptive, the {n} windows the nearer surface decides: sigma median {np.median(sig):.1f}; "
      f"centre more than sigma_c off its own surface's median grey in {off}")
for i in range(4):
    print(f"    nearer samples {bins[i]}-{bins[i+1]} sigma from the centre's grey: {cnt[i]/n:.1f} a window, "
          f"{100*tot[i]/n:.1f}% of the variance")
