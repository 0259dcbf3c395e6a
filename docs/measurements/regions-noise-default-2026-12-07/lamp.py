# Where Regions' new defaults (prior_flat_noise, prior_region_cover_band = 3) trade within 1%
# for within 2% on a scene: per view, the finest-scale region planes of both settings, what
# their prior and the final depth give the pixels they paint, within 1% and 2% of the truth.
# Usage: lamp.py SCENE_DIR
import sys, pathlib, warnings, numpy as np, matplotlib
matplotlib.use("Agg"); import matplotlib.pyplot as plt
import mvscope
root = pathlib.Path(sys.argv[1])
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(root, max_image_size=320)
def resized(path, shape):
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0]), 0, a.shape[0] - 1)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1]), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
settings = {"before": {"prior_flat_noise": False, "prior_region_cover_band": 0.0}, "now": {}}
out = {}
for name, params in settings.items():
    s = mvscope.Session(scene, method="regions", seed=0, params=params)
    last = s.num_levels - 1
    s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
    views = {}
    for v in scene.views:
        m, mesh = s.maps(v.index), s.prior_mesh(v.index)
        r = mesh["regions"]
        rows, cols = np.arange(m.height)[:, None] // r["cell"], np.arange(m.width) // r["cell"]
        views[v.index] = dict(plane=r["plane"][rows, cols].copy(), prior=m["prior_depth"].copy(),
                              planes=r["planes"], shape=(m.height, m.width))
    s.run()
    for v in scene.views:
        views[v.index]["final"] = s.maps(v.index)["depth"].copy()
    out[name] = views
def within(d, gt, t):
    return (d > 0) & (gt > 0) & (np.abs(d - gt) <= t * gt)
for v in scene.views:
    b, n = out["before"][v.index], out["now"][v.index]
    gt = resized(root / "gt" / f"{v.scene_index:08d}.pfm", b["shape"])
    weak = resized(root / "gt" / f"{v.scene_index:08d}_lowtex.png", b["shape"]) & (gt > 0)
    valid = gt > 0
    print(f"view {v.index}: valid {int(valid.sum())}, weak {int(weak.sum())}")
    for name, x in (("before", b), ("now", n)):
        f1, f2 = within(x["final"], gt, 0.01), within(x["final"], gt, 0.02)
        print(f"  {name:6s} final within 1% {f1[valid].mean():.3f} (weak {f1[weak].mean():.3f}), "
              f"within 2% {f2[valid].mean():.3f} (weak {f2[weak].mean():.3f}); "
              f"painted by a plane {int((x['plane'] >= 0)[valid].sum())}")
    # Pixels that turned: within 1% before and not now, and the other way.
    lost1 = within(b["final"], gt, 0.01) & ~within(n["final"], gt, 0.01) & valid
    won2 = ~within(b["final"], gt, 0.02) & within(n["final"], gt, 0.02) & valid
    lost2 = within(b["final"], gt, 0.02) & ~within(n["final"], gt, 0.02) & valid
    for what, mask in (("lost within 1%", lost1), ("won within 2%", won2), ("lost within 2%", lost2)):
        pb, pn = b["plane"][mask], n["plane"][mask]
        print(f"  {what}: {int(mask.sum())} px; painted before {int((pb >= 0).sum())}, now {int((pn >= 0).sum())}, "
              f"now by a plane where before none {int(((pn >= 0) & (pb < 0)).sum())}")
    print("  planes now, largest first: pixels; prior within 1% / 2%; final within 1% / 2% now | before on the same pixels; painted before")
    sizes = [(int((n["plane"] == k).sum()), k) for k in range(len(n["planes"]))]
    for size, k in sorted(sizes, reverse=True)[:12]:
        p = (n["plane"] == k) & valid
        if p.sum() == 0: continue
        ys, xs = np.nonzero(p)
        pr1, pr2 = within(n["prior"], gt, 0.01)[p].mean(), within(n["prior"], gt, 0.02)[p].mean()
        fn1, fn2 = within(n["final"], gt, 0.01)[p].mean(), within(n["final"], gt, 0.02)[p].mean()
        fb1, fb2 = within(b["final"], gt, 0.01)[p].mean(), within(b["final"], gt, 0.02)[p].mean()
        before = (b["plane"][p] >= 0).mean()
        print(f"   plane {k:2d} ({len(n['planes'][k]['inliers'])} inliers) x {xs.min()}-{xs.max()} y {ys.min()}-{ys.max()}: "
              f"{int(p.sum())} px; prior {pr1:.2f} / {pr2:.2f}; final {fn1:.2f} / {fn2:.2f} | {fb1:.2f} / {fb2:.2f}; painted before {before:.2f}")
