# The shipped ICL's view 3 (Regions' defaults, 320, seed 0), after the finest planar prior:
# region 1's support points and the planes RANSAC found for it, and what they paint.
import warnings, numpy as np, mvscope
I = '/work/shared/data/rgbd/icl-livingroom'
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(I, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0)
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
mesh = s.prior_mesh(3)
r = mesh["regions"]
reg, pl = np.asarray(r["region"]), np.asarray(r["plane"])
print("mesh keys", sorted(mesh.keys()), "sizes", r["sizes"][:10] if hasattr(r["sizes"], "__len__") else r["sizes"])
pts = mesh["points"]
print("points", type(pts), len(pts) if hasattr(pts, "__len__") else "")
cell = r["cell"]
cx = reg.shape[1] if reg.ndim == 2 else None
xs, ys = np.asarray(pts["x"]) if isinstance(pts, dict) else None, None
need = int(np.ceil(0.25 * r["sizes"][0]))
print("region 1 points", r["sizes"][0], "quarter", need)
for k, p in enumerate(r["planes"]):
    print("plane", k, "region", p["region"], "inliers", len(p["inliers"]), "normal", np.round(p["plane"][:3], 3).tolist(),
          "cells painted", int((pl == k).sum()))
print("cells in region 1", int((reg == 1).sum()), "painted by any plane", int((pl >= 0).sum()))
print("points dtype", pts.dtype if hasattr(pts, "dtype") else type(pts[0]), pts.shape)
print("params tolerance", s.params.get("prior_region_tolerance"))
gt = mvscope.read_pfm(f'{I}/gt/00000003.pfm')
W, H = mesh["width"], mesh["height"]
d = np.asarray(mesh["point_depth"])
px, py = pts[:, 0], pts[:, 1]
g = gt[np.clip(((py + 0.5) * gt.shape[0] / H).astype(int), 0, gt.shape[0] - 1), np.clip(((px + 0.5) * gt.shape[1] / W).astype(int), 0, gt.shape[1] - 1)]
inreg = reg[py // cell, px // cell] == 1
rel = np.abs(d / np.where(g > 0, g, 1) - 1)
print(f"giant region's points {int(inreg.sum())}: within 1% of the truth {float((rel[inreg] <= 0.01).mean()):.3f}, within 2% {float((rel[inreg] <= 0.02).mean()):.3f}, median |rel| {float(np.median(rel[inreg])):.4f}, median est/gt {float(np.median((d / np.where(g > 0, g, 1))[inreg])):.4f}")
# The truth's own best plane share: points whose TRUE depth lies within 1% of the left half's least-squares plane in inverse depth
for name, side in (("left half (x < W/2)", px < W / 2), ("right half", px >= W / 2)):
    m = inreg & side & (g > 0)
    A = np.c_[px[m], py[m], np.ones(m.sum())]
    coef, *_ = np.linalg.lstsq(A, 1 / g[m], rcond=None)
    fit = 1 / (np.c_[px, py, np.ones(len(px))] @ coef)
    on_true = inreg & (np.abs(g / fit - 1) <= 0.01) & (g > 0)
    on_est = inreg & (np.abs(d / fit - 1) <= 0.01)
    print(f"  {name}: the truth's plane there holds {int(on_true.sum())} of the region's points by their true depth, {int(on_est.sum())} by their estimated depth (quarter {need})")
rng = np.random.default_rng(0)
idx = np.nonzero(inreg & (g > 0))[0]
U = np.c_[px[idx], py[idx], np.ones(len(idx))].astype(float)
def best(depth):
    inv = 1 / depth[idx]
    top, top_n = None, 0
    for _ in range(3000):
        t = rng.choice(len(idx), 3, replace=False)
        try:
            coef = np.linalg.solve(U[t], inv[t])
        except np.linalg.LinAlgError:
            continue
        pred = U @ coef
        with np.errstate(divide="ignore"):
            n = int((np.abs(inv / pred - 1) <= 0.01).sum())  # |d_plane/d - 1|, about the relative depth error
        if n > top_n:
            top, top_n = coef, n
    return top_n
print(f"RANSAC (3000 triples, 1%) over the giant region's {len(idx)} points with truth: best plane holds {best(g)} by true depth, {best(d)} by estimated depth; the quarter is {need}")
