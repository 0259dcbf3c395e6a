"""kitchen-a (colour focal length), 320, seed 0: each view's largest flat region at the end
of the finest prior stage, followed back through the run. At the end of every stage, how
many of that region's pixels are within 2% / 5% of the truth, and within 2% once the
view's median est/gt is divided out? Where does the wall's depth go wrong?"""
import sys
import pathlib
import numpy as np
sys.path.insert(0, str(pathlib.Path(__file__).parent.parent / "table-2026-12-02"))
from truth import at_finest_prior, truth, resized
import mvscope

d = sys.argv[1] if len(sys.argv) > 1 else "/tmp/s30/kroot/rgbd/kitchen-a"
method = sys.argv[2] if len(sys.argv) > 2 else "regions"
scene, s = at_finest_prior(d)
masks = []
for v in range(len(scene.views)):
    mesh, m = s.prior_mesh(v), s.maps(v)
    r = mesh["regions"]; c = r["cell"]
    big = int(np.argmax(np.array(r["sizes"]))) + 1
    ys, xs = np.mgrid[0:m.height, 0:m.width]
    masks.append(r["region"][ys // c, xs // c] == big)
s = mvscope.Session(scene, method=method, seed=0)
ends = {}
for st in s.steps:
    ends[(st["level"], st["stage"])] = st["index"] + 1
print("stages:", list(ends), flush=True)
for (level, stage), k in sorted(ends.items(), key=lambda e: e[1]):
    s.goto(k)
    rows = []
    for v in range(len(scene.views)):
        m = s.maps(v)
        if m is None: continue
        gt, _ = truth(d, f"{v:08d}", (m.height, m.width))
        reg = resized(masks[v].astype(np.uint8), (m.height, m.width)) > 0
        sel = reg & (gt > 0)
        est = m["depth"][sel]; g = gt[sel]
        ok = est > 0
        rel = np.abs(est - g) / g
        ratio = np.median(est[ok] / g[ok]) if ok.any() else np.nan
        relf = np.abs(est / ratio - g) / g
        rows.append((100 * np.mean(ok & (rel <= 0.02)), 100 * np.mean(ok & (rel <= 0.05)),
                     100 * np.mean(ok & (relf <= 0.02)), ratio))
    a = np.array(rows)
    print(f"level {level} {stage:>22}: region within 2% {a[:,0].mean():5.1f}, 5% {a[:,1].mean():5.1f}, "
          f"scale-free 2% {a[:,2].mean():5.1f}, median est/gt {np.nanmedian(a[:,3]):.3f}; per view 2%: "
          + " ".join(f"{x:.0f}" for x in a[:, 0]), flush=True)
