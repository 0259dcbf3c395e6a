"""Kitchen-a: the flat regions without a plane: their size, points, and the best plane's share."""
import pathlib, sys, warnings
import numpy as np
import mvscope
from PIL import Image
from common import KITCHEN_A, at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else KITCHEN_A)
scene = open_scene(room)
def truth(view, shape, suffix=".pfm"):
    p = room / "gt" / f"{view.scene_index:08d}{suffix}"
    if not p.exists(): return np.zeros(shape, bool)
    return rs(mvscope.read_pfm(p) if suffix == ".pfm" else np.asarray(Image.open(p)) > 0, shape)
s = at_prior_end(scene)
rng = np.random.default_rng(0)
rows = []
for v in scene.views:
    m = s.maps(v.index); mesh = s.prior_mesh(v.index); H, W = m.height, m.width
    g = truth(v, (H, W)); wk = truth(v, (H, W), "_lowtex.png") & (g > 0)
    K = v.K if hasattr(v, "K") else None
    R = mesh["regions"]; c = R["cell"]; cw = R["region"].shape[1]
    P = mesh["points"]; pd = mesh["point_depth"]
    preg = R["region"][P[:, 1] // c, P[:, 0] // c]
    has = set(p["region"] + 1 for p in R["planes"])
    gp = g[P[:, 1], P[:, 0]]
    for r in range(1, len(R["sizes"]) + 1):
        idx = np.where(preg == r)[0]
        cells = (R["region"] == r).sum()
        yy, xx = np.mgrid[0:H, 0:W]
        rm = R["region"][yy // c, xx // c] == r
        nweak = (rm & wk).sum()
        if nweak < 50: continue
        ok2 = ((gp[idx] > 0) & (np.abs(pd[idx] - gp[idx]) <= 0.02 * gp[idx])).mean() if len(idx) else 0
        ok5 = ((gp[idx] > 0) & (np.abs(pd[idx] - gp[idx]) <= 0.05 * gp[idx])).mean() if len(idx) else 0
        # truth plane share: fit inverse-depth plane to the truth at the points' pixels, ransac on points (u,v,1/d)
        best = 0
        if len(idx) >= 3:
            u = P[idx].astype(float); q = 1 / pd[idx]
            A = np.c_[u, np.ones(len(idx))]
            for _ in range(300):
                t = rng.choice(len(idx), 3, replace=False)
                try: abc = np.linalg.solve(A[t], q[t])
                except np.linalg.LinAlgError: continue
                inv = A @ abc
                err = np.abs(1 / np.maximum(inv, 1e-9) - pd[idx]) / pd[idx]
                best = max(best, ((err <= 0.01) & (inv > 0)).mean())
        rows.append((v.index, r, cells, len(idx), nweak, r in has, ok2, ok5, best))
        print(f"view {v.index} region {r:3d} cells {cells:5d} points {len(idx):5d} weak px {nweak:6d} plane {str(r in has):5} pts right 2% {ok2:.2f} 5% {ok5:.2f} best plane share {best:.2f}", flush=True)
