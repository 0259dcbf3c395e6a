"""kitchen-a (colour focal length), 320, seed 0: each view's largest flat region at the end
of the finest prior stage. Is it one surface (the truth's best plane over its pixels within
1% / 3% of the truth), and how far do its support points lie from that plane?"""
import sys
import numpy as np
from truth import at_finest_prior, truth
d = sys.argv[1] if len(sys.argv) > 1 else "/tmp/s30/kroot/rgbd/kitchen-a"
scene, s = at_finest_prior(d)
for v in range(len(scene.views)):
    mesh, m = s.prior_mesh(v), s.maps(v)
    gt, _ = truth(d, f"{v:08d}", (m.height, m.width))
    r = mesh["regions"]; c = r["cell"]
    sizes = np.array(r["sizes"]); big = int(np.argmax(sizes)) + 1
    ys, xs = np.mgrid[0:m.height, 0:m.width]
    inreg = (r["region"][ys // c, xs // c] == big) & (gt > 0)
    k = np.array(scene.views[v].K) * (m.width / scene.views[v].width)
    u = (xs - k[0, 2]) / k[0, 0]; w = (ys - k[1, 2]) / k[1, 1]
    A = np.stack([u[inreg], w[inreg], np.ones(inreg.sum())], 1)
    abc, *_ = np.linalg.lstsq(A, 1 / gt[inreg], rcond=None)
    plane_d = 1 / (A @ abc)
    rel = np.abs(plane_d - gt[inreg]) / gt[inreg]
    p = mesh["points"]; dep = mesh["point_depth"]
    pin = r["region"][p[:, 1] // c, p[:, 0] // c] == big
    pu = (p[pin, 0] - k[0, 2]) / k[0, 0]; pw = (p[pin, 1] - k[1, 2]) / k[1, 1]
    ppd = 1 / (abc[0] * pu + abc[1] * pw + abc[2])
    prel = np.abs(dep[pin] - ppd) / ppd
    pg = gt[p[pin, 1], p[pin, 0]]
    ptrue = np.abs(dep[pin] - pg) / np.where(pg > 0, pg, 1)
    print(f"view {v}: region {big}, {sizes[big-1]} points, {inreg.sum()} px; truth's plane holds its pixels within 1% {100*np.mean(rel<=0.01):.0f}%, 3% {100*np.mean(rel<=0.03):.0f}%; "
          f"points within 1% of that plane {100*np.mean(prel<=0.01):.0f}%, 3% {100*np.mean(prel<=0.03):.0f}%, median {100*np.median(prel):.1f}%; "
          f"points within 2% of their truth {100*np.mean((ptrue<=0.02)&(pg>0)):.0f}%", flush=True)
