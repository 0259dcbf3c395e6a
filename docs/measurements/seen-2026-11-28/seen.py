"""A room: share of pixels (all, weak) whose truth point no other view sees, and how ACMM and
Regions end within 2% on seen and unseen pixels."""
import pathlib, sys
import numpy as np, mvscope
from PIL import Image
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "reach-2026-11-28"))  # common.py
from common import open_scene, rs
room = pathlib.Path(sys.argv[1])
scene = open_scene(room); V = scene.views
G, WK = [], []
for v in V:
    H, W = v.height, v.width
    g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
    w = room / "gt" / f"{v.scene_index:08d}_lowtex.png"
    WK.append((rs(np.asarray(Image.open(w)) > 0, (H, W)) if w.exists() else np.zeros((H, W), bool)) & (g > 0)); G.append(g)
def world(v, d):
    H, W = d.shape; y, x = np.mgrid[0:H, 0:W]
    ray = np.linalg.inv(v.K) @ np.stack([x.ravel(), y.ravel(), np.ones(H * W)])
    return v.R.T @ (ray * d.ravel() - v.t[:, None])
SEEN = []
for v in V:
    X = world(v, G[v.index]); seen = np.zeros(X.shape[1], int)
    for u in V:
        if u.index == v.index: continue
        Xc = u.R @ X + u.t[:, None]; z = Xc[2]; p = u.K @ Xc
        with np.errstate(all="ignore"):
            xs = np.round(p[0] / z); ys = np.round(p[1] / z)
        H, W = G[u.index].shape
        inb = (z > 0) & (xs >= 0) & (ys >= 0) & (xs < W) & (ys < H)
        xs = np.clip(np.nan_to_num(xs), 0, W - 1).astype(int); ys = np.clip(np.nan_to_num(ys), 0, H - 1).astype(int)
        gt = G[u.index][ys, xs]; seen += inb & (np.abs(gt - z) <= 0.03 * z)
    SEEN.append(seen.reshape(G[v.index].shape) > 0)
res = {}
for meth in sys.argv[2:] or ["acmm", "regions"]:
    s = mvscope.Session(scene, method=meth, seed=0); s.run()
    res[meth] = [np.abs(s.depth(v.index) - G[v.index]) <= 0.02 * G[v.index] for v in V]
for name, M in (("all", [g > 0 for g in G]), ("weak", WK)):
    n = sum(m.sum() for m in M); ns = sum((m & S).sum() for m, S in zip(M, SEEN))
    line = f"{room.name} {name}: unseen by others {100*(n-ns)/n:.1f}%"
    for meth, OK in res.items():
        a = sum((m & o).sum() for m, o in zip(M, OK)); b = sum((m & o & S).sum() for m, o, S in zip(M, OK, SEEN))
        line += f" | {meth} within 2% all {100*a/n:.1f} seen {100*b/ns:.1f} unseen {100*(a-b)/max(n-ns,1):.1f}"
    print(line)
