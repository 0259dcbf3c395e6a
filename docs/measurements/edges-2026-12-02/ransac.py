"""Dolls view 1, flat as weighed and edge rule: the region over the bottom-right corner at the
end of the finest scale's prior stage. Its support points against the truth; every triple's
plane scored as fit_regions scores them (points within 1% of depth along their rays)."""
import sys, pathlib, warnings, itertools
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene_dir = pathlib.Path("/work/shared/data/middlebury2006/Dolls"); v = 1
scene = mvscope.Scene.open(scene_dir, max_image_size=320)
def resized(path, shape):
    a = mvscope.read_pfm(path)
    rows = np.clip(np.round((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0] - 0.5), 0, a.shape[0] - 1)
    cols = np.clip(np.round((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1] - 0.5), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
s = mvscope.Session(scene, method="regions", seed=0, params={"prior_flat_weighted": True, "prior_region_edge": True})
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
mesh, m = s.prior_mesh(v), s.maps(v)
r = mesh["regions"]; c = r["cell"]
gt = resized(scene_dir / "gt" / f"{v:08d}.pfm", (m.height, m.width))
rid = r["region"][230 // c, 290 // c]
pts = mesh["points"]; dep = mesh["point_depth"]
inreg = r["region"][pts[:, 1] // c, pts[:, 0] // c] == rid
P = pts[inreg]; D = dep[inreg].astype(np.float64); T = gt[P[:, 1], P[:, 0]].astype(np.float64)
K = scene.views[v].K
u = (P[:, 0] - K[0, 2]) / K[0, 0]; w_ = (P[:, 1] - K[1, 2]) / K[1, 1]
print(f"region {rid}: {inreg.sum()} points; right within 2% of the truth: {np.mean(np.abs(D-T) <= 0.02*T)*100:.0f}%;"
      f" rel err median {np.median((D-T)/T):.3f}")
A = np.stack([u, w_, np.ones_like(u)], 1); inv = 1 / D
best = []
for t in itertools.combinations(range(len(D)), 3):
    try:
        abc = np.linalg.solve(A[list(t)], inv[list(t)])
    except np.linalg.LinAlgError:
        continue
    pred = A @ abc
    ok = pred > 0
    e = np.where(ok, np.abs(1 / np.where(ok, pred, 1) - D) / D, np.inf)
    n = int(np.sum(e <= 0.01)); best.append((n, float(np.sum(e[e <= 0.01])), tuple(abc)))
best.sort(key=lambda b: (-b[0], b[1]))
seen = []
for n, sm, abc in best:
    if any(np.allclose(abc, q, rtol=0.02, atol=1e-4) for q in seen):
        continue
    seen.append(abc)
    predT = A @ np.array(abc)
    right = np.mean(np.abs(1 / predT - T) <= 0.02 * T) * 100
    print(f"  plane holding {n} points (err sum {sm:.3f}): right at {right:.0f}% of the region's points' pixels")
    if len(seen) >= 6:
        break
for k, p in enumerate(r["planes"]):
    if p["region"] + 1 == rid:
        n, w, = p["plane"][:3], p["plane"][3]
        ray = np.stack([u, w_, np.ones_like(u)], 1)
        d = -w / (ray @ n)
        print(f"  found: plane {k} holds {len(p['inliers'])}; right at {np.mean(np.abs(d - T) <= 0.02*T)*100:.0f}% of the points' pixels")
