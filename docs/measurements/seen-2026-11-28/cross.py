"""Registered ICL: for each view's weak pixels without a prior, which other views see their truth
point (visible by the truth there) and hold it within 2% at the prior stage (prior or depth) and
at the end."""
import pathlib, sys
import numpy as np, mvscope
from PIL import Image
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "reach-2026-11-28"))  # common.py
from common import at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1])
scene = open_scene(room)
s = at_prior_end(scene)
V = scene.views
G, WK, HOLE, PR, D0 = [], [], [], [], []
for v in V:
    m = s.maps(v.index); H, W = m.height, m.width
    g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
    w = room / "gt" / f"{v.scene_index:08d}_lowtex.png"
    wk = rs(np.asarray(Image.open(w)) > 0, (H, W)) & (g > 0)
    G.append(g); WK.append(wk); HOLE.append(wk & (m["prior_depth"] <= 0)); PR.append(m["prior_depth"].copy()); D0.append(m["depth"].copy())
s.run()
DE = [s.depth(v.index) for v in V]
def world(v, d):
    H, W = d.shape; y, x = np.mgrid[0:H, 0:W]
    ray = np.linalg.inv(v.K) @ np.stack([x.ravel(), y.ravel(), np.ones(H * W)])
    Xc = ray * d.ravel(); return v.R.T @ (Xc - v.t[:, None])
for v in V:
    hole = HOLE[v.index]; X = world(v, G[v.index])[:, hole.ravel()]
    okend = (np.abs(DE[v.index] - G[v.index]) <= 0.02 * G[v.index])[hole]
    seen = np.zeros(X.shape[1], int); pr_ok = np.zeros(X.shape[1], bool); d0_ok = pr_ok.copy(); de_ok = pr_ok.copy()
    for u in V:
        if u.index == v.index: continue
        Xc = u.R @ X + u.t[:, None]; z = Xc[2]; p = u.K @ Xc
        xs = np.round(p[0] / z).astype(int); ys = np.round(p[1] / z).astype(int)
        H, W = G[u.index].shape
        inb = (z > 0) & (xs >= 0) & (ys >= 0) & (xs < W) & (ys < H)
        xs, ys = np.clip(xs, 0, W - 1), np.clip(ys, 0, H - 1)
        gt = G[u.index][ys, xs]; vis = inb & (np.abs(gt - z) <= 0.02 * z)
        seen += vis
        pr_ok |= vis & (np.abs(PR[u.index][ys, xs] - z) <= 0.02 * z)
        d0_ok |= vis & (np.abs(D0[u.index][ys, xs] - z) <= 0.02 * z)
        de_ok |= vis & (np.abs(DE[u.index][ys, xs] - z) <= 0.02 * z)
    n = hole.sum()
    print(f"view {v.index}: holes {n}, end right {100*okend.mean():.1f}%; seen by 0/1/2+ others {100*(seen==0).mean():.0f}/{100*(seen==1).mean():.0f}/{100*(seen>=2).mean():.0f}%; "
          f"another view's prior right {100*pr_ok.mean():.1f}%, prior-stage depth right {100*d0_ok.mean():.1f}%, end depth right {100*de_ok.mean():.1f}%; "
          f"of those with another's prior right, end right here {100*okend[pr_ok].mean() if pr_ok.any() else 0:.1f}%")
