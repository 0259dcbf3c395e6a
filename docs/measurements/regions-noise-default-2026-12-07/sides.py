# The support points of each large finest-scale region plane, by the side of the plane they
# miss it on, and how those sides lie in the image: of the points missed within the band
# (b tolerances), the share that has a point missed on the other side in one of its 8
# neighbouring cells (a join count: noise mixes the sides cell by cell; a plane through a
# curved surface or across a fold leaves them in patches). Writes PLANES_VIEW{v}.png.
# Usage: sides.py SCENE_DIR OUT_PREFIX [NAME=VALUE...]
import sys, pathlib, warnings, numpy as np, matplotlib
matplotlib.use("Agg"); import matplotlib.pyplot as plt
import mvscope
root, prefix = pathlib.Path(sys.argv[1]), sys.argv[2]
sets = {k: (v if not v.replace('.', '').isdigit() else float(v)) for k, v in (a.split("=") for a in sys.argv[3:])}
for k, v in sets.items():
    if v in ("true", "false"): sets[k] = v == "true"
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(root, max_image_size=320)
def resized(path, shape):
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0]), 0, a.shape[0] - 1)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1]), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
s = mvscope.Session(scene, method="regions", seed=0, params=sets)
p = s.params
tol, band = p["prior_region_tolerance"], p["prior_region_cover_band"] or 3.0
print("settings:", sets or "Regions' defaults", f"(tolerance {tol}, band read at {band} tolerances)")
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
for v in scene.views:
    m, mesh = s.maps(v.index), s.prior_mesh(v.index)
    r = mesh["regions"]; c = r["cell"]
    gt = resized(root / "gt" / f"{v.scene_index:08d}.pfm", (m.height, m.width))
    prior = m["prior_depth"]
    pts, dep = mesh["points"], mesh["point_depth"]
    cell_of = (pts[:, 1] // c, pts[:, 0] // c)
    fig, ax = plt.subplots(figsize=(8, 8 * m.height / m.width))
    ax.imshow(m["image"] if "image" in m.keys() else np.zeros((m.height, m.width)), cmap="gray")
    print(f"view {v.index}:")
    sizes = [(int((r["plane"] == k).sum()), k) for k in range(len(r["planes"]))]
    for size, k in sorted(sizes, reverse=True)[:8]:
        mine = r["plane"][cell_of] == k
        idx = np.nonzero(mine)[0]
        if len(idx) == 0: continue
        x, y, d = pts[idx, 0], pts[idx, 1], dep[idx]
        dp = prior[y, x]
        res = (dp - d) / d
        held = np.abs(res) <= tol
        near = (~held) & (res < 0) & (-res <= band * tol)   # the point lies behind the plane
        far = (~held) & (res > 0) & (res <= band * tol)
        # join count over the cell grid
        side = np.zeros(r["plane"].shape, np.int8)
        side[y[near] // c, x[near] // c] = -1
        side[y[far] // c, x[far] // c] = 1
        mixed = 0
        for i in np.nonzero(near | far)[0]:
            gy, gx = y[i] // c, x[i] // c
            nb = side[max(gy - 1, 0):gy + 2, max(gx - 1, 0):gx + 2]
            mixed += int((nb == -side[gy, gx]).any())
        # Opposite-side joins between band points in neighbouring cells (8-neighbourhood),
        # against their distribution when the sides are shuffled among the same points.
        bi = np.nonzero(near | far)[0]
        lab = np.where(near[bi], -1, 1)
        gyx = np.stack([y[bi] // c, x[bi] // c], 1)
        adj = [(a, b) for a in range(len(bi)) for b in range(a + 1, len(bi))
               if np.abs(gyx[a] - gyx[b]).max() <= 1]
        adj = np.array(adj, np.int64).reshape(-1, 2)
        obs = int((lab[adj[:, 0]] != lab[adj[:, 1]]).sum()) if len(adj) else 0
        rng = np.random.default_rng(0)
        null = np.array([(l[adj[:, 0]] != l[adj[:, 1]]).sum() for l in (rng.permutation(lab) for _ in range(400))]) if len(adj) else np.zeros(1)
        pval = (null <= obs).mean()
        z = (obs - null.mean()) / max(null.std(), 1e-9)
        g = gt[y, x]
        right = (g > 0) & (np.abs(d - g) <= 0.01 * g)
        cells = r["plane"] == k
        pr = cells.repeat(c, 0).repeat(c, 1)[:m.height, :m.width] & (gt > 0)
        prior_right = (np.abs(prior - gt) <= 0.02 * gt)[pr].mean() if pr.any() else float("nan")
        nb = int((near | far).sum())
        print(f"  plane {k:2d}: {size} cells, {len(idx)} points in them ({right.mean():.2f} within 1% of the truth): "
              f"held {held.sum()}, nearer {near.sum()}, farther {far.sum()}, beyond {len(idx) - held.sum() - nb}; "
              f"band points with the other side beside them {mixed}/{nb} ({mixed / max(nb, 1):.2f}); "
              f"opposite joins {obs} against {null.mean():.1f} shuffled (ratio {obs / max(null.mean(), 1e-9):.2f}, z {z:+.1f}, p {pval:.3f}); prior within 2% on {prior_right:.2f} of its pixels")
        ax.scatter(x[held], y[held], s=3, c="lime"); ax.scatter(x[near], y[near], s=3, c="red"); ax.scatter(x[far], y[far], s=3, c="cyan")
        ax.text(x.mean(), y.mean(), str(k), color="yellow")
    ax.set_axis_off(); fig.savefig(f"{prefix}_view{v.index}.png", dpi=80, bbox_inches="tight"); plt.close(fig)
