"""Regions on the registered ICL at 320, seed 0, with and without prior_region_crease:
which planes view 3's regions take, and how right each plane is over the cells it paints."""
import sys
import numpy as np
import mvscope

GT = "/tmp/scenes/extra/rgbd/icl-reg"
VIEW = 3
scene = mvscope.Scene.open(GT, max_image_size=320)
g = mvscope.read_pfm(f"{GT}/gt/{VIEW:08}.pfm")
for crease in (False, True):
    s = mvscope.Session(scene, method="regions", seed=0, params={"prior_region_crease": crease})
    s.run()
    m = s.prior_mesh(VIEW)
    r = m["regions"]
    K = scene[VIEW].K
    h, w = m["height"], m["width"]
    gy = np.arange(h) * g.shape[0] // h
    gx = np.arange(w) * g.shape[1] // w
    truth = g[gy][:, gx]
    depth = s.maps(VIEW)["depth"]
    print(f"crease={crease}: {len(r['planes'])} planes")
    c = r["cell"]
    for k, p in enumerate(r["planes"]):
        cells = np.argwhere(r["plane"] == k)
        if len(cells) == 0:
            continue
        n, wv = p["plane"][:3], p["plane"][3]
        ys, xs = np.mgrid[0:h, 0:w]
        mask = np.zeros((h, w), bool)
        for cy, cx in cells:
            mask[cy * c:(cy + 1) * c, cx * c:(cx + 1) * c] = True
        rays = np.stack([(xs - K[0, 2]) / K[0, 0], (ys - K[1, 2]) / K[1, 1], np.ones_like(xs, float)], -1)
        d = -wv / (rays @ n)
        ok = mask & (truth > 0)
        rel = np.abs(d - truth)[ok] / truth[ok]
        est = np.abs(depth - truth)[ok] / truth[ok]
        xs_ = cells[:, 1] * c
        print(f"  plane {k} region {p['region']} inliers {len(p['inliers'])} cells {len(cells)} "
              f"x {xs_.min()}-{xs_.max() + c}: plane within 2% {np.mean(rel <= 0.02):.3f}, "
              f"median plane/truth {np.median(d[ok] / truth[ok]):.3f}, final depth within 2% {np.mean(est <= 0.02):.3f}")
