import pathlib, sys, warnings, numpy as np, mvscope
from common import KITCHEN_A, at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1]); vi = int(sys.argv[2])
scene = open_scene(room)
s = at_prior_end(scene)
v = scene.views[vi]; mesh = s.prior_mesh(vi); R = mesh["regions"]; c = R["cell"]
g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (v.height, v.width))
P = mesh["points"]; pd = mesh["point_depth"]; K = v.K
preg = R["region"][P[:, 1] // c, P[:, 0] // c]
big = np.bincount(preg)[1:].argmax() + 1
idx = np.where(preg == big)[0]
left = np.setdiff1d(idx, np.concatenate([p["inliers"] for p in R["planes"] if p["region"] == big - 1]))
gp = g[P[:, 1], P[:, 0]]; right = np.abs(pd - gp) <= 0.02 * gp
print("region points", len(idx), "left", len(left), "left right", right[left].mean().round(2))
rng = np.random.default_rng(0)
A = np.c_[(P[:, 0] - K[0, 2]) / K[0, 0], (P[:, 1] - K[1, 2]) / K[1, 1], np.ones(len(P))]; q = 1 / pd
for k in range(4):
    best, bi = 0, None
    for _ in range(1000):
        t = rng.choice(left, 3, replace=False)
        try: abc = np.linalg.solve(A[t], q[t])
        except np.linalg.LinAlgError: continue
        inv = A[left] @ abc; ok = (inv > 0) & (np.abs(1 / np.maximum(inv, 1e-12) - pd[left]) <= 0.01 * pd[left])
        if ok.sum() > best: best, bi = ok.sum(), ok
    inl = left[bi]
    print(f"plane {k+1}: holds {best} = {best/len(idx):.2f} of region, {best/len(left):.2f} of left; inliers right {right[inl].mean():.2f}; spread", np.sqrt(np.linalg.eigvalsh(np.cov(P[inl].T.astype(float)))).round(1))
    left = left[~bi]
