import pathlib, sys, warnings, numpy as np, mvscope
from common import KITCHEN_A, at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1])
scene = open_scene(room)
s = at_prior_end(scene)
for v in scene.views:
    m = s.maps(v.index); mesh = s.prior_mesh(v.index); H, W = m.height, m.width
    g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
    R = mesh["regions"]; c = R["cell"]; yy, xx = np.mgrid[0:H, 0:W]
    pl = R["plane"][yy // c, xx // c]
    q = (m["prior_depth"] == -2) & (pl >= 0) & (g > 0)
    K = v.K; rx = (xx - K[0, 2]) / K[0, 0]; ry = (yy - K[1, 2]) / K[1, 1]
    planes = np.array([p["plane"] for p in R["planes"]]) if R["planes"] else np.zeros((0, 4))
    if not q.any(): print(v.index, "none"); continue
    P = planes[pl[q]]
    den = P[:, 0] * rx[q] + P[:, 1] * ry[q] + P[:, 2]
    d = np.where(den < 0, -P[:, 3] / np.minimum(den, -1e-9), -1)
    e = np.abs(d - g[q]) / g[q]
    print(v.index, "range", v.depth_range, "px", q.sum(), "truth p5/50/95", np.percentile(g[q], [5, 50, 95]).round(2),
          "plane depth p5/50/95", np.percentile(d, [5, 50, 95]).round(2), "plane within 2%", round(100 * (e <= 0.02).mean(), 1),
          "truth beyond range", round(100 * ((g[q] > v.depth_range.max) | (g[q] < v.depth_range.min)).mean(), 1))
print("--- per plane")
for v in scene.views:
    m = s.maps(v.index); mesh = s.prior_mesh(v.index); H, W = m.height, m.width
    g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
    R = mesh["regions"]; c = R["cell"]; yy, xx = np.mgrid[0:H, 0:W]
    pl = R["plane"][yy // c, xx // c]; pr = m["prior_depth"]
    P = mesh["points"]; pd = mesh["point_depth"]
    for k, p in enumerate(R["planes"]):
        q = (pl == k) & (g > 0)
        inl = p["inliers"]; xy = P[inl].astype(float)
        ev = np.linalg.eigvalsh(np.cov(xy.T)) if len(inl) > 2 else [0, 0]
        gi = g[P[inl, 1], P[inl, 0]]
        ok_in = (np.abs(pd[inl] - gi) <= 0.02 * gi).mean()
        okp = ((np.abs(pr - g) <= 0.02 * g) & (pr > 0) & q).sum() / max(q.sum(), 1)
        oor = ((pr == -2) & q).sum() / max(q.sum(), 1)
        print(f"view {v.index} plane {k} region {p['region']} cells {int((R['plane']==k).sum())} inliers {len(inl)} of {R['sizes'][p['region']]} sd {np.sqrt(np.maximum(ev,0)).round(1)} inliers right {ok_in:.2f} painted right {okp:.2f} out of range {oor:.2f} normal {p['plane'][:3].round(2)}")
