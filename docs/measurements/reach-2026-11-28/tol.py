"""Kitchen-a: fit the cabinet region's points with RANSAC at several tolerances; how right is the plane."""
import pathlib, sys, warnings
import numpy as np, mvscope
from common import KITCHEN_A, at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else KITCHEN_A)
scene = open_scene(room)
s = at_prior_end(scene)
rng = np.random.default_rng(0)
for v in scene.views:
    m = s.maps(v.index); mesh = s.prior_mesh(v.index); H, W = m.height, m.width
    g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
    R = mesh["regions"]; c = R["cell"]
    yy, xx = np.mgrid[0:H, 0:W]; reg = R["region"][yy // c, xx // c]
    big = np.bincount(reg.ravel())[1:].argmax() + 1; mk = (reg == big) & (g > 0)
    P = mesh["points"]; pd = mesh["point_depth"]
    idx = np.where(R["region"][P[:, 1] // c, P[:, 0] // c] == big)[0]
    K = v.K; f = K[0, 0]
    # baselines to the sources (perpendicular to the optical axis)
    C = v.center; z = v.R[2]
    bs = []
    for src in v.sources:
        o = scene.views[src.view]
        b = o.center - C; bs.append(np.linalg.norm(b - (b @ z) * z))
    dmed = np.median(pd[idx])
    u = (P[idx, 0] - K[0, 2]) / K[0, 0]; w_ = (P[idx, 1] - K[1, 2]) / K[1, 1]
    A = np.c_[u, w_, np.ones(len(idx))]; q = 1 / pd[idx]
    U = (xx - K[0, 2]) / K[0, 0]; V = (yy - K[1, 2]) / K[1, 1]
    line = f"view {v.index} pts {len(idx)} baselines {np.round(sorted(bs), 3)} 1px at d={dmed:.2f}: {100*dmed/(f*max(bs)):.1f}%..{100*dmed/(f*np.median(bs)):.1f}%"
    for tol in (0.01, 0.03, 0.05, 0.08, 0.12):
        best, bi = -1, None
        for _ in range(512):
            t = rng.choice(len(idx), 3, replace=False)
            try: abc = np.linalg.solve(A[t], q[t])
            except np.linalg.LinAlgError: continue
            inv = A @ abc; ok = (inv > 0) & (np.abs(1 / np.maximum(inv, 1e-9) - pd[idx]) <= tol * pd[idx])
            if ok.sum() > best: best, bi = ok.sum(), ok
        abc = np.linalg.lstsq(A[bi], q[bi], rcond=None)[0]
        dep = 1 / np.maximum(abc[0] * U + abc[1] * V + abc[2], 1e-9)
        e = np.abs(dep - g)[mk] / g[mk]
        line += f" | tol {tol:.2f}: share {best/len(idx):.2f} plane 2% {100*(e<=0.02).mean():4.1f} 5% {100*(e<=0.05).mean():4.1f}"
    print(line, flush=True)
