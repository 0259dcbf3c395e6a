"""kitchen-a (colour focal length), 320, seed 0, Regions at the end of the finest prior
stage: each view's largest flat region, whose own support points are right 8-16% of the
time (largest.py). Would the points just outside it do better? For the ring of cells within
`r` cells of the region (not in it): how many hold a support point, how many of those are
within 2% of their own truth, and how many lie within 2% of the region's truth plane (the
plane a fit over region and ring would need)."""
import sys
import pathlib
import numpy as np
sys.path.insert(0, str(pathlib.Path(__file__).parent.parent / "table-2026-12-02"))
from truth import at_finest_prior, truth

d = sys.argv[1] if len(sys.argv) > 1 else "/tmp/s30/kroot/rgbd/kitchen-a"
scene, s = at_finest_prior(d)
for v in range(len(scene.views)):
    mesh, m = s.prior_mesh(v), s.maps(v)
    gt, _ = truth(d, f"{v:08d}", (m.height, m.width))
    r = mesh["regions"]; c = r["cell"]; reg = r["region"]
    big = int(np.argmax(np.array(r["sizes"]))) + 1
    inr = reg == big
    ys, xs = np.mgrid[0:m.height, 0:m.width]
    inreg = (reg[ys // c, xs // c] == big) & (gt > 0)
    k = np.array(scene.views[v].K) * (m.width / scene.views[v].width)
    nu = lambda x: (x - k[0, 2]) / k[0, 0]; nv = lambda y: (y - k[1, 2]) / k[1, 1]
    A = np.stack([nu(xs[inreg]), nv(ys[inreg]), np.ones(inreg.sum())], 1)
    abc, *_ = np.linalg.lstsq(A, 1 / gt[inreg], rcond=None)
    p = mesh["points"]; dep = mesh["point_depth"]
    pc = (p[:, 1] // c, p[:, 0] // c)
    pg = gt[p[:, 1], p[:, 0]]
    plane_d = 1 / (abc[0] * nu(p[:, 0]) + abc[1] * nv(p[:, 1]) + abc[2])
    own = (pg > 0) & (np.abs(dep - pg) <= 0.02 * np.where(pg > 0, pg, 1))
    onp = np.abs(dep - plane_d) <= 0.02 * plane_d
    truth_on = (pg > 0) & (np.abs(pg - plane_d) <= 0.02 * plane_d)
    line = [f"view {v}: region {inr.sum()} cells, {(inr[pc]).sum()} points: right {100*own[inr[pc]].mean():.0f}%, on plane {100*onp[inr[pc]].mean():.0f}%"]
    grown = inr.copy()
    done = 0
    for ring in (1, 2, 4):
        while done < ring:  # 4-connected steps of one cell
            g = grown.copy()
            g[1:] |= grown[:-1]; g[:-1] |= grown[1:]; g[:, 1:] |= grown[:, :-1]; g[:, :-1] |= grown[:, 1:]
            grown = g; done += 1
        sel = grown & ~inr
        pin = sel[pc]
        line.append(f"ring {ring}: {pin.sum()} points, right {100*own[pin].mean():.0f}%, on plane {100*onp[pin].mean():.0f}%, truth on plane {100*truth_on[pin].mean():.0f}%")
    print("; ".join(line), flush=True)
