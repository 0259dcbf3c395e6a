"""Registered ICL: the weak pixels no source sees under a right region plane: where their final
Regions depth projects (inside a source image or not), for those ending right and wrong, with
their final cost and depth / truth."""
import pathlib, sys
import numpy as np, mvscope
from PIL import Image
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "reach-2026-11-28"))  # common.py
from common import at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1])
scene = open_scene(room); V = scene.views
s = at_prior_end(scene)
G, WK, CL = [], [], []
for v in V:
    m, mesh = s.maps(v.index), s.prior_mesh(v.index); H, W = m.height, m.width
    g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
    wk = rs(np.asarray(Image.open(room / "gt" / f"{v.scene_index:08d}_lowtex.png")) > 0, (H, W)) & (g > 0)
    r = mesh["regions"]; c = r["cell"]
    plane = r["plane"][np.arange(H)[:, None] // c, np.arange(W) // c]
    pr = m["prior_depth"]; right = (pr > 0) & (np.abs(pr - g) <= 0.02 * g)
    cl = np.full((H, W), "none", object)
    cl[(pr > 0) & (plane >= 0) & right] = "reg+"; cl[(pr > 0) & (plane >= 0) & ~right] = "reg-"
    cl[(pr > 0) & (plane < 0) & right] = "tri+"; cl[(pr > 0) & (plane < 0) & ~right] = "tri-"
    G.append(g); WK.append(wk); CL.append(cl)
def world(v, d):
    H, W = d.shape; y, x = np.mgrid[0:H, 0:W]
    ray = np.linalg.inv(v.K) @ np.stack([x.ravel(), y.ravel(), np.ones(H * W)])
    return v.R.T @ (ray * d.ravel() - v.t[:, None])
SEEN = []
for v in V:
    X = world(v, G[v.index]); seen = np.zeros(X.shape[1], bool)
    for src in v.sources:
        u = V[src.view]; Xc = u.R @ X + u.t[:, None]; z = Xc[2]; p = u.K @ Xc
        with np.errstate(all="ignore"):
            xs = np.round(p[0] / z); ys = np.round(p[1] / z)
        H, W = G[u.index].shape
        inb = (z > 0) & (xs >= 0) & (ys >= 0) & (xs < W) & (ys < H)
        xs = np.clip(np.nan_to_num(xs), 0, W - 1).astype(int); ys = np.clip(np.nan_to_num(ys), 0, H - 1).astype(int)
        gt = G[u.index][ys, xs]; seen |= inb & ~((gt > 0) & (gt < z * 0.97))
    SEEN.append(seen.reshape(G[v.index].shape))

s.run()
def inframe(v, d):
    X = world(v, d); any_in = np.zeros(X.shape[1], bool)
    for src in v.sources:
        u = V[src.view]; Xc = u.R @ X + u.t[:, None]; z = Xc[2]; p = u.K @ Xc
        with np.errstate(all="ignore"):
            xs = p[0] / z; ys = p[1] / z
        H, W = G[u.index].shape
        any_in |= (z > 0) & (xs >= -0.5) & (ys >= -0.5) & (xs < W - 0.5) & (ys < H - 0.5)
    return any_in.reshape(d.shape)
for v in V:
    g = G[v.index]; d = s.depth(v.index); ok = np.abs(d - g) <= 0.02 * g
    cost = s.maps(v.index)["cost"]
    cls = WK[v.index] & ~SEEN[v.index] & (CL[v.index] == "reg+")
    if cls.sum() < 200: continue
    fin = inframe(v, d)
    for name, m in (("right", cls & ok), ("wrong", cls & ~ok)):
        if m.sum() == 0: continue
        print(f"view {v.index} unseen reg+ ending {name}: {m.sum()} px; final depth lands in a source {100*fin[m].mean():.1f}%; "
              f"median cost {np.median(cost[m]):.3f}; median depth/truth {np.median(d[m]/g[m]):.3f}")
