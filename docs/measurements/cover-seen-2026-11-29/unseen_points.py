import numpy as np, mvscope, pathlib
d = np.load("/tmp/s26/points.npz")
out = pathlib.Path("/tmp/s25/bimodal/scene")
sc = mvscope.Scene.open(out)
cell = int(d["cell"])
for v in range(5):
    V = sc.views[v]
    pts, pd, reg = d[f"pts{v}"], d[f"pd{v}"], d[f"reg{v}"]
    g = mvscope.read_pfm(out / "gt" / f"{v:08d}.pfm")
    r = reg[pts[:, 1] // cell, pts[:, 0] // cell]
    sel = np.where(r == 1)[0]
    gd = g[pts[sel, 1], pts[sel, 0]]
    ok = np.abs(pd[sel] / gd - 1) <= 0.01
    # world points at true depth
    x = np.c_[pts[sel], np.ones(len(sel))].T.astype(float)
    Xc = np.linalg.inv(V.K) @ x * gd
    Xw = V.R.T @ (Xc - V.t[:, None])
    seen = np.zeros(len(sel), bool)
    lines = open(out / "pair.txt").read().split("\n")
    # find sources
    srcs = [s for s in range(5) if s != v]
    for s in srcs:
        S = sc.views[s]
        p = S.K @ (S.R @ Xw + S.t[:, None])
        z = p[2]; u, w = p[0] / z, p[1] / z
        H, W = S.image().shape[:2]
        seen |= (z > 0) & (u >= 0) & (u <= W - 1) & (w >= 0) & (w <= H - 1)
    print(f"v{v}: region 1 {len(sel)} pts; right {ok.sum()} (unseen {(ok & ~seen).sum()}); wrong {(~ok).sum()} (unseen {(~ok & ~seen).sum()})")
