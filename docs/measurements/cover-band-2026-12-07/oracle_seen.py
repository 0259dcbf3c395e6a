# The cover test of each finest-scale region plane recomputed from its points, over all of
# them and over only the points the truth says some source sees (an oracle of visibility):
# would a check of occlusion drop the wrong planes the band keeps and keep the right ones?
# Usage: oracle_seen.py SCENE BAND [NAME=VALUE...]   (BAND in tolerances, 0: the plain test)
import sys, pathlib, warnings, numpy as np, matplotlib
matplotlib.use("Agg"); import matplotlib.pyplot as plt
import mvscope
room = pathlib.Path(sys.argv[1]); band = float(sys.argv[2]); sets = sys.argv[3:]
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0, params={k: v for k, v in (a.split("=") for a in sets)})
tol = s.params["prior_region_tolerance"]
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
def cam(i):
    t = (room / "cams" / f"{i:08d}_cam.txt").read_text().split()
    return np.array(t[1:17], float).reshape(4, 4), np.array(t[18:27], float).reshape(3, 3)
pairs = (room / "pair.txt").read_text().split("\n")
print(f"settings: {' '.join(sets) or 'defaults'}; band {band}")
for v in scene.views:
    i = v.scene_index
    m, mesh = s.maps(v.index), s.prior_mesh(v.index)
    gtf = mvscope.read_pfm(room / "gt" / f"{i:08d}.pfm"); sc = m.width / gtf.shape[1]
    E, K = cam(i)
    srcs = [int(a) for a in pairs[2 + 2 * i].split()[1::2]]
    pts = np.asarray(mesh["points"], float); d = np.asarray(mesh["point_depth"], float)
    # truth visibility of each point's pixel
    fx_, fy_ = np.clip(np.round((pts[:, 0] + 0.5) / sc - 0.5), 0, gtf.shape[1] - 1).astype(int), np.clip(np.round((pts[:, 1] + 0.5) / sc - 0.5), 0, gtf.shape[0] - 1).astype(int)
    z = gtf[fy_, fx_]
    pc = np.linalg.inv(K) @ np.stack([fx_, fy_, np.ones(len(pts))]) * z
    pw = np.linalg.inv(E) @ np.vstack([pc, np.ones(len(pts))])
    nseen = np.zeros(len(pts), int)
    for sidx in srcs:
        Es, Ks = cam(sidx); gs = mvscope.read_pfm(room / "gt" / f"{sidx:08d}.pfm")
        q = Es @ pw; uv = Ks @ q[:3]; u, w_ = uv[0] / uv[2], uv[1] / uv[2]
        inside = (q[2] > 0) & (u >= 0) & (u < gs.shape[1] - 0.5) & (w_ >= 0) & (w_ < gs.shape[0] - 0.5)
        ds = np.zeros(len(pts)); ui = np.clip(np.round(u).astype(int), 0, gs.shape[1] - 1); vi = np.clip(np.round(w_).astype(int), 0, gs.shape[0] - 1)
        ds[inside] = gs[vi[inside], ui[inside]]
        nseen += inside & (np.abs(ds - q[2]) <= 0.01 * q[2])
    r = mesh["regions"]; c = r["cell"]
    cellplane = r["plane"][(pts[:, 1] // c).astype(int), (pts[:, 0] // c).astype(int)]
    k320 = K.copy(); k320[:2] *= sc
    ray = np.stack([(pts[:, 0] - k320[0, 2]) / k320[0, 0], (pts[:, 1] - k320[1, 2]) / k320[1, 1], np.ones(len(pts))])
    gt = gtf[np.ix_(np.clip(np.floor((np.arange(m.height) + 0.5) / sc), 0, gtf.shape[0] - 1).astype(int), np.clip(np.floor((np.arange(m.width) + 0.5) / sc), 0, gtf.shape[1] - 1).astype(int))]
    plane_px = r["plane"][np.arange(m.height)[:, None] // c, np.arange(m.width) // c]
    prior = m["prior_depth"]; right = (prior > 0) & (gt > 0) & (np.abs(prior - gt) <= 0.02 * gt)
    print(f"view {v.index}: {len(r['planes'])} planes")
    for k, pl in enumerate(r["planes"]):
        px = plane_px == k
        if px.sum() < 100: continue
        n = np.asarray(pl["plane"], float)
        dp = -n[3] / (n[:3] @ ray)
        res = (dp - d) / d
        t = cellplane == k
        def cover(sel):
            tot = int(sel.sum())
            if tot == 0: return "   -  "
            held = sel & (np.abs(res) <= tol)
            near = int((sel & ~held & (res < 0) & (-res <= band * tol)).sum()); far = int((sel & ~held & (res >= 0) & (res <= band * tol)).sum())
            return f"{(held.sum() + 2 * min(near, far)) / tot:5.2f} ({tot:3d})"
        print(f"   plane {k:2d}: pixels {int(px.sum()):5d} right {right[px].mean():4.2f}; cover all {cover(t)}, "
              f"seen by 1+ {cover(t & (nseen >= 1))}, 2+ {cover(t & (nseen >= 2))}")
