import numpy as np, sys
d = np.load("/tmp/s26/points.npz")
g_dir = "/tmp/s25/bimodal/scene/gt"

import mvscope
tol = 0.01
def plane(P):  # LS 1/d = a u + b v + c
    A = np.c_[P[:, 0], P[:, 1], np.ones(len(P))]
    sol, *_ = np.linalg.lstsq(A, P[:, 2], rcond=None); return sol
def err(abc, P):
    inv = P[:, 0] * abc[0] + P[:, 1] * abc[1] + abc[2]
    e = np.abs(1 / inv - 1 / P[:, 2]) * P[:, 2]; e[inv <= 0] = np.inf; return e
for v in range(5):
    pts, pd, reg, K, cell = d[f"pts{v}"], d[f"pd{v}"], d[f"reg{v}"], d[f"K{v}"], int(d["cell"])
    g = mvscope.read_pfm(f"{g_dir}/{v:08d}.pfm")
    r = reg[pts[:, 1] // cell, pts[:, 0] // cell]
    ids, cnt = np.unique(r[r > 0], return_counts=True); big = ids[np.argmax(cnt)]
    sel = r == big
    P = np.c_[(pts[sel, 0] - K[0, 2]) / K[0, 0], (pts[sel, 1] - K[1, 2]) / K[1, 1], 1 / pd[sel]]
    G = np.c_[P[:, :2], 1 / g[pts[sel, 1], pts[sel, 0]]]
    truth_plane = plane(G)
    gt_hold = (err(truth_plane, P) <= tol).sum()
    gt_flat = (err(truth_plane, G) <= 0.001).sum()
    rng = np.random.default_rng(v)
    best = None
    for _ in range(256):
        t = rng.choice(len(P), 3, replace=False)
        try: abc = np.linalg.solve(np.c_[P[t, :2], np.ones(3)], P[t, 2])
        except np.linalg.LinAlgError: continue
        n = (err(abc, P) <= tol).sum()
        if best is None or n > best[1]: best = (abc, n)
    abc, n0 = best
    hist = [n0]
    for it in range(10):
        inl = err(abc, P) <= tol
        abc2 = plane(P[inl]); n2 = (err(abc2, P) <= tol).sum()
        if n2 <= hist[-1]: break
        abc = abc2; hist.append(n2)
    print(f"v{v}: {sel.sum()} pts; truth is one plane: {gt_flat}/{sel.sum()}; truth plane holds {gt_hold}; ransac best triple {n0}, refits {hist}; mvscope planes {d[f'planes{v}'].tolist()} regions {d[f'preg{v}'].tolist()}")
