# View 3 of the shipped ICL (Regions, 320, seed 0): plain RANSAC (256 triples, one refit) vs
# LO-RANSAC (each new best refitted to its inliers until the count stops growing).
import warnings, numpy as np, mvscope, sys
I = '/work/shared/data/rgbd/icl-livingroom'
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(I, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0)
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
for view in [int(a) for a in sys.argv[1:]] or [3]:
    mesh = s.prior_mesh(view)
    r = mesh["regions"]; reg = np.asarray(r["region"]); cell = r["cell"]
    pts = np.asarray(mesh["points"]); d = np.asarray(mesh["point_depth"], float)
    px, py = pts[:, 0], pts[:, 1]
    lab = reg[py // cell, px // cell]
    big = np.bincount(lab[lab > 0]).argmax()
    m = (lab == big) & (d > 0)
    U = np.c_[px[m], py[m], np.ones(m.sum())].astype(float); inv = 1 / d[m]
    n = len(inv); need = int(np.ceil(0.25 * n))
    def score(c):
        pred = U @ c
        with np.errstate(divide="ignore", invalid="ignore"):
            e = np.where(pred > 0, np.abs(1 / pred - 1 / inv) * inv, np.inf)
        ok = e <= 0.01
        return int(ok.sum()), float(e[ok].sum()), ok
    def fit(mask):
        c, *_ = np.linalg.lstsq(U[mask], inv[mask], rcond=None); return c
    def ransac(rng, lo, k=256):
        best = None
        for _ in range(k):
            t = rng.integers(0, n, 3)
            if len(set(t)) < 3: continue
            try: c = np.linalg.solve(U[t], inv[t])
            except np.linalg.LinAlgError: continue
            sc = score(c)
            if best is None or (sc[0], -sc[1]) > (best[1][0], -best[1][1]):
                if lo:
                    for _ in range(20):
                        c2 = fit(sc[2]); s2 = score(c2)
                        if s2[0] <= sc[0]: break
                        c, sc = c2, s2
                best = (c, sc)
        c, sc = best
        c2 = fit(sc[2]); s2 = score(c2)
        if s2[0] >= sc[0]: c, sc = c2, s2
        return sc[0]
    for lo in (False, True):
        got = [ransac(np.random.default_rng(k), lo) for k in range(10)]
        print(f"view {view} region {big}: {n} points, quarter {need}; {'LO' if lo else 'plain'} 256: {got}")
