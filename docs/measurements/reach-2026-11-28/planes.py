"""A region's further planes: what tells the right ones from the wrong (registered ICL, view 3's
largest region): the inliers' spatial compactness, their costs, their normals' agreement."""
import pathlib, sys
import numpy as np
import mvscope
from common import at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1]); vi = int(sys.argv[2])
scene = open_scene(room)
s = at_prior_end(scene)
v = scene.views[vi]; mesh = s.prior_mesh(vi); R = mesh["regions"]; c = R["cell"]
g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (v.height, v.width))
P = mesh["points"]; pd = mesh["point_depth"]; K = v.K; cost = mesh["point_cost"]; nrm = mesh["point_normal"]
preg = R["region"][P[:, 1] // c, P[:, 0] // c]
big = np.bincount(preg)[1:].argmax() + 1
idx = np.where(preg == big)[0]
first = [p for p in R["planes"] if p["region"] == big - 1]
left = np.setdiff1d(idx, np.concatenate([p["inliers"] for p in first]))
gp = g[P[:, 1], P[:, 0]]; right = np.abs(pd - gp) <= 0.02 * gp
rng = np.random.default_rng(0)
A = np.c_[(P[:, 0] - K[0, 2]) / K[0, 0], (P[:, 1] - K[1, 2]) / K[1, 1], np.ones(len(P))]; q = 1 / pd
def describe(name, inl, abc):
    cells = set(zip((P[inl, 0] // c).tolist(), (P[inl, 1] // c).tolist()))
    nb = [sum((x + dx, y + dy) in cells for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy) for x, y in cells]
    n = -abc / np.linalg.norm(abc)  # the plane's normal (camera frame), as plane_of
    agree = (nrm[inl] @ n) >= np.cos(np.radians(20))
    print(f"{name}: {len(inl)} points, right {right[inl].mean():.2f}; cells with 2+ inlier neighbours {np.mean(np.array(nb) >= 2):.2f}; "
          f"median cost {np.median(cost[inl]):.3f}; normals within 20 deg {agree.mean():.2f}")
abc0 = np.linalg.lstsq(A[first[0]["inliers"]], q[first[0]["inliers"]], rcond=None)[0]
describe("first plane", first[0]["inliers"], abc0)
for k in range(4):
    best, bi, babc = 0, None, None
    for _ in range(1000):
        t = rng.choice(left, 3, replace=False)
        try: abc = np.linalg.solve(A[t], q[t])
        except np.linalg.LinAlgError: continue
        inv = A[left] @ abc; ok = (inv > 0) & (np.abs(1 / np.maximum(inv, 1e-12) - pd[left]) <= 0.01 * pd[left])
        if ok.sum() > best: best, bi, babc = ok.sum(), ok, abc
    describe(f"further plane {k + 1}", left[bi], babc)
    left = left[~bi]
