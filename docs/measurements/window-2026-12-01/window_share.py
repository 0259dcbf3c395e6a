"""Which samples decide a weak window beside an object in front: through Session.inspect's
`window`, the share of the window's weighted variance held by samples on a nearer surface
(truth depth < 95% of the centre's), per bilateral kernel, on view 0's weak pixels beside
such an edge; and on textured pixels, how many samples' worth of weight the window keeps."""
import sys, pathlib, warnings
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

offs = np.arange(-5, 6, 2)
def pick(gt, weak, rng):
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
    pe = [edge[i] for i in rng.choice(len(edge), min(n_pix, len(edge)), replace=False)]
    pt = [tex[i] for i in rng.choice(len(tex), min(n_pix, len(tex)), replace=False)]
    return pe, pt, len(edge)

rng = np.random.default_rng(0)
results = {}
for kernel in ["laplacian", "gaussian", "adaptive"]:
    s = mvscope.Session(scene, method="acmh", seed=0, params={"bilateral_kernel": kernel})
    first = next(st["index"] for st in s.steps if st["view"] == 0 and st.get("half") == "red")
    s.goto(first + 1)
    m = s.maps(0)
    gt = resized(scene_dir / "gt" / "00000000.pfm", (m.height, m.width))
    weak = resized(scene_dir / "gt" / "00000000_lowtex.png", (m.height, m.width)) & (gt > 0)
    if kernel == "laplacian":
        pe, pt, n_edge = pick(gt, weak, rng)
    shares, decided, eff_tex = [], 0, []
    for x, y, near in pe:
        win = s.inspect(0, int(x), int(y))["window"]
        sh = np.asarray(win["variance_share"], dtype=np.float64)[np.ix_(offs + 5, offs + 5)]
        held = float(np.nansum(sh[near]))
        shares.append(held)
        decided += held > 0.5
    for x, y, _ in pt:
        eff_tex.append(s.inspect(0, int(x), int(y))["window"]["effective"])
    results[kernel] = (np.mean(shares), decided / len(pe), np.median(eff_tex))
    print(f"{kernel:9s}: weak pixels beside a nearer surface ({len(pe)} of {n_edge}): "
          f"its samples hold {100*np.mean(shares):.1f}% of the variance on average, "
          f"over half in {100*decided/len(pe):.1f}%; textured pixels ({len(pt)}): "
          f"median (sum w)^2/sum w^2 {np.median(eff_tex):.1f} of 36", flush=True)
