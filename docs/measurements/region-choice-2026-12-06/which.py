"""Regions with `prior_region_choice`: at the finest scale, per view, the region planes that
kept the restorer's fit and those that took the later fit (the first geometric pass's
points), the pixels each paints and the share within 2% of the truth."""
import sys
import numpy as np
import mvscope

GT = sys.argv[1]
scene = mvscope.Scene.open(GT, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0, params={"prior_region_choice": True})
s.run()
tot = {False: [0, 0], True: [0, 0]}
for v in range(len(scene)):
    m = s.prior_mesh(v)
    r = m["regions"]
    h, w, c = m["height"], m["width"], r["cell"]
    g = mvscope.read_pfm(f"{GT}/gt/{v:08}.pfm")
    truth = g[np.arange(h) * g.shape[0] // h][:, np.arange(w) * g.shape[1] // w]
    K = scene[v].K
    ys, xs = np.mgrid[0:h, 0:w]
    rays = np.stack([(xs - K[0, 2]) / K[0, 0], (ys - K[1, 2]) / K[1, 1], np.ones_like(xs, float)], -1)
    k = r["plane"][ys // c, xs // c]
    line = []
    for later in (False, True):
        right = painted = 0
        for i, p in enumerate(r["planes"]):
            if p["later"] != later:
                continue
            mask = (k == i) & (truth > 0)
            n, wv = np.asarray(p["plane"][:3], float), float(p["plane"][3])
            d = -wv / (rays[mask] @ n)
            right += int(np.sum(np.abs(d - truth[mask]) <= 0.02 * truth[mask]))
            painted += int(mask.sum())
        tot[later][0] += right
        tot[later][1] += painted
        n_planes = sum(p["later"] == later for p in r["planes"])
        line.append(f"{'later' if later else 'earlier'}: {n_planes} planes, {painted} px, "
                    f"{right / max(painted, 1):.3f} right")
    print(f"view {v}: " + " | ".join(line))
for later, (right, painted) in tot.items():
    print(f"{'later' if later else 'earlier'} planes: {painted} px painted, {right} right "
          f"({right / max(painted, 1):.3f})")
