import pickle, numpy as np, sys
sys.path.insert(0, "/tmp/diag"); exec(open("/tmp/diag/conf.py").read().split("C = {m")[0])
P = pickle.load(open(D + "/prior.pkl", "rb"))
rng = np.random.default_rng(0)
def fit(uvd):
    A = np.c_[uvd[:, 0], uvd[:, 1], np.ones(len(uvd))]
    return np.linalg.lstsq(A, 1 / uvd[:, 2], rcond=None)[0]
def err(abc, uvd):
    inv = uvd[:, 0] * abc[0] + uvd[:, 1] * abc[1] + abc[2]
    d = np.where(inv > 0, 1 / np.where(inv > 0, inv, 1), np.inf)
    return np.abs(d - uvd[:, 2]) / uvd[:, 2]
def ransac(uvd, n=2000):
    best = (0, None)
    for _ in range(n):
        t = rng.choice(len(uvd), 3, replace=False)
        try: abc = np.linalg.solve(np.c_[uvd[t, 0], uvd[t, 1], np.ones(3)], 1 / uvd[t, 2])
        except np.linalg.LinAlgError: continue
        s = (err(abc, uvd) <= 0.01).sum()
        if s > best[0]: best = (s, abc)
    abc = best[1]; inl = err(abc, uvd) <= .01; abc2 = fit(uvd[inl])
    if (err(abc2, uvd) <= .01).sum() >= inl.sum(): abc = abc2
    return abc, err(abc, uvd) <= .01
for i in [1, 2]:
    v = views[i]; p = P[i]; Kinv = np.linalg.inv(v["K"]); g = gt_at(v)
    pts = np.asarray(p["points"]); dep = np.asarray(p["point_depth"])
    cell = p["cell"]; reg = p["region"][pts[:, 1] // cell, pts[:, 0] // cell]
    big = np.argmax(p["sizes"]) + 1
    sel = np.nonzero(reg == big)[0]
    uv = (np.c_[pts[sel], np.ones(len(sel))] @ Kinv.T)[:, :2]
    uvd = np.c_[uv, dep[sel]]
    held = np.zeros(len(pts), bool); held[np.asarray(p["planes"][0]["inliers"])] = True
    left = ~held[sel]
    print(f"view {i}: region {big} points {len(sel)}, plane 0 holds {held[sel].sum()}, left {left.sum()}")
    rest = uvd[left]; idx = sel[left]
    for k in range(4):
        if len(rest) < 6: break
        abc, inl = ransac(rest)
        xy = pts[idx[inl]]
        gt_ok = np.mean([abs(dep[j] - g[pts[j,1], pts[j,0]]) / g[pts[j,1], pts[j,0]] <= .02 for j in idx[inl] if g[pts[j,1], pts[j,0]] > 0])
        print(f"  plane {k+1}: holds {inl.sum()} of {len(rest)} left; x {np.percentile(xy[:,0],[5,50,95])}, y {np.percentile(xy[:,1],[5,50,95])}; points right (2%) {gt_ok:.2f}")
        rest = rest[~inl]; idx = idx[~inl]
