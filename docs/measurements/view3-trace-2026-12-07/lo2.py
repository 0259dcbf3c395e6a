import warnings, numpy as np, mvscope, sys
I = '/work/shared/data/rgbd/icl-livingroom'
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(I, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0)
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
view = 3
mesh = s.prior_mesh(view)
r = mesh["regions"]; reg = np.asarray(r["region"]); cell = r["cell"]
pts = np.asarray(mesh["points"]); d = np.asarray(mesh["point_depth"], float)
W, H = mesh["width"], mesh["height"]
gt = mvscope.read_pfm(f'{I}/gt/00000003.pfm')
px, py = pts[:, 0], pts[:, 1]
g = gt[np.clip(((py + 0.5) * gt.shape[0] / H).astype(int), 0, gt.shape[0] - 1), np.clip(((px + 0.5) * gt.shape[1] / W).astype(int), 0, gt.shape[1] - 1)]
lab = reg[py // cell, px // cell]
m = (lab == 1) & (d > 0)
U = np.c_[px[m], py[m], np.ones(m.sum())].astype(float); inv = 1 / d[m]; G = g[m]
n = len(inv); need = int(np.ceil(0.25 * n))
def err(c, invs=inv):
    pred = U @ c
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(pred > 0, (1 / pred - 1 / invs) * invs, np.inf)  # signed: plane - point, relative
def ransac(rng, alive, k=256):
    idx = np.nonzero(alive)[0]; best = None
    for _ in range(k):
        t = idx[rng.integers(0, len(idx), 3)]
        if len(set(t)) < 3: continue
        try: c = np.linalg.solve(U[t], inv[t])
        except np.linalg.LinAlgError: continue
        e = np.abs(err(c)); ok = (e <= 0.01) & alive
        sc = (int(ok.sum()), -float(e[ok].sum()))
        if best is None or sc > best[1]: best = (c, sc, ok)
    c, sc, ok = best
    c2, *_ = np.linalg.lstsq(U[ok], inv[ok], rcond=None)
    ok2 = (np.abs(err(c2)) <= 0.01) & alive
    return (c2, ok2) if ok2.sum() >= ok.sum() else (c, ok)
rng = np.random.default_rng(0)
alive = np.ones(n, bool)
for k in range(4):
    c, ok = ransac(rng, alive)
    e = err(c)
    near = ((e < 0) & (-e <= 0.03) & ~ok).sum(); far = ((e >= 0) & (e <= 0.03) & ~ok).sum()
    # truth of inliers: is the plane right there?
    tr = np.abs(1 / (U[ok] @ c) / G[ok] - 1)
    xs = U[ok, 0]; ys = U[ok, 1]
    # where the truth itself lies on this plane
    on_truth = (np.abs(1 / (U @ c) / G - 1) <= 0.01) & (G > 0)
    print(f"plane {k}: holds {ok.sum()} of {alive.sum()} left (need {need}); band near {near} far {far}; "
          f"cover if alone: ({ok.sum()} + {2*min(near,far)}) / {n} = {(ok.sum()+2*min(near,far))/n:.2f}; "
          f"inliers x {np.percentile(xs,[10,50,90]).round()} y {np.percentile(ys,[10,50,90]).round()}; "
          f"plane within 1% of truth at its inliers {np.mean(tr<=0.01):.2f}; truth on plane: {on_truth.sum()} points")
    if ok.sum() < need: break
    alive &= ~ok
c0 = None
rng = np.random.default_rng(0); alive = np.ones(n, bool); c0, ok0 = ransac(rng, alive)
e0 = err(c0)
on_truth = (np.abs(1 / (U @ c0) / G - 1) <= 0.01) & (G > 0)
cw, ch = reg.shape[1], reg.shape[0]
grid = np.full((ch, cw), ' ')
grid[reg == 1] = ','
for i in range(n):
    x, y = int(U[i,0]) // cell, int(U[i,1]) // cell
    if ok0[i]: ch_ = '#'
    elif on_truth[i]: ch_ = '+' if e0[i] > 0 else '-'   # wall point, estimate off: + plane farther than point (point nearer)
    else: ch_ = '.'
    grid[y, x] = ch_
print("cell", cell, "grid", cw, ch)
print("\n".join("".join(row) for row in grid))
wall = on_truth
print("left-wall points (truth):", wall.sum(), "held", (ok0 & wall).sum(), "off & point nearer than plane", ((~ok0) & wall & (e0 > 0)).sum(), "farther", ((~ok0) & wall & (e0 < 0)).sum())
print("median |e| of unheld wall points", np.median(np.abs(e0[wall & ~ok0])))
rel = d[m] / np.where(G > 0, G, np.nan) - 1
for name, sel in (("left wall x<34 cells", U[:,0] < 170), ("right x>=36 cells, y>12 cells", (U[:,0] >= 180) & (U[:,1] >= 60)), ("top right (ceiling?)", (U[:,0] >= 90) & (U[:,1] < 50))):
    r_ = rel[sel]
    print(f"{name}: {sel.sum()} pts, median est/gt-1 {np.nanmedian(r_):+.4f}, within 1% {np.nanmean(np.abs(r_)<=0.01):.2f}, 2% {np.nanmean(np.abs(r_)<=0.02):.2f}, 5% {np.nanmean(np.abs(r_)<=0.05):.2f}")
# does the truth of the right wall fit a plane?
sel = (U[:,0] >= 180) & (U[:,1] >= 60) & (G > 0)
c, *_ = np.linalg.lstsq(U[sel], 1 / G[sel], rcond=None)
print("right wall truth plane fit: within 1%", np.mean(np.abs(1 / (U[sel] @ c) / G[sel] - 1) <= 0.01))
ce, *_ = np.linalg.lstsq(U[sel], inv[sel], rcond=None)
print("right wall estimate LS plane vs truth plane at those points: median rel", np.median(np.abs((U[sel]@c)/(U[sel]@ce) - 1)))
