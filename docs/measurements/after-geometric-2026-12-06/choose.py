"""Regions' region planes at the finest scale, built from the restorer's result (default) and
after the first geometric pass (`prior_after_geometric`), region by region: how right each
set is over the cells it paints (truth within 2%), and what a per-region choice by the
planes' support would give. The flat regions depend on the images only, so both runs share
them."""
import sys
import numpy as np
import mvscope

GT = sys.argv[1]
SIZE = 320


def planes_by_region(m, truth, K):
    r = m["regions"]
    c = r["cell"]
    h, w = m["height"], m["width"]
    ys, xs = np.mgrid[0:h, 0:w]
    rays = np.stack([(xs - K[0, 2]) / K[0, 0], (ys - K[1, 2]) / K[1, 1], np.ones_like(xs, float)], -1)
    out = {}
    region = r["region"]
    for k, p in enumerate(r["planes"]):
        cells = np.argwhere(r["plane"] == k)
        if len(cells) == 0:
            continue
        n, wv = np.asarray(p["plane"][:3]), p["plane"][3]
        mask = np.zeros((h, w), bool)
        for cy, cx in cells:
            mask[cy * c:(cy + 1) * c, cx * c:(cx + 1) * c] = True
        ok = mask & (truth > 0)
        d = -wv / (rays @ n)
        right = int(np.sum(np.abs(d[ok] - truth[ok]) <= 0.02 * truth[ok]))
        reg = int(region[cells[0][0], cells[0][1]])
        e = out.setdefault(reg, {"inliers": 0, "pixels": 0, "right": 0, "planes": 0})
        e["inliers"] += len(p["inliers"])
        e["pixels"] += int(ok.sum())
        e["right"] += right
        e["planes"] += 1
    sizes = r["sizes"]
    for reg, e in out.items():
        e["size"] = int(sizes[reg - 1])
    return out


scene = mvscope.Scene.open(GT, max_image_size=SIZE)
runs = {}
for name, params in [("default", {}), ("after", {"prior_after_geometric": True})]:
    s = mvscope.Session(scene, method="regions", seed=0, params=params)
    s.run()
    runs[name] = s
tot = {"default": [0, 0], "after": [0, 0], "more": [0, 0], "share": [0, 0]}
for v in range(len(scene)):
    g = mvscope.read_pfm(f"{GT}/gt/{v:08}.pfm")
    md, ma = runs["default"].prior_mesh(v), runs["after"].prior_mesh(v)
    h, w = md["height"], md["width"]
    truth = g[np.arange(h) * g.shape[0] // h][:, np.arange(w) * g.shape[1] // w]
    K = scene[v].K
    pd, pa = planes_by_region(md, truth, K), planes_by_region(ma, truth, K)
    same = np.array_equal(md["regions"]["region"], ma["regions"]["region"])
    line = [f"view {v} (regions shared: {same})"]
    for reg in sorted(set(pd) | set(pa)):
        d, a = pd.get(reg), pa.get(reg)
        for key, e in [("default", d), ("after", a)]:
            if e:
                tot[key][0] += e["right"]
                tot[key][1] += e["pixels"]
        # A choice by support: the set whose planes hold more of their region's points.
        share = lambda e: e["inliers"] / max(e["size"], 1) if e else -1
        more = d if (a is None or (d is not None and d["inliers"] >= a["inliers"])) else a
        by_share = d if share(d) >= share(a) else a
        for key, e in [("more", more), ("share", by_share)]:
            if e:
                tot[key][0] += e["right"]
                tot[key][1] += e["pixels"]
        if (d and d["pixels"] > 300) or (a and a["pixels"] > 300):
            f = lambda e: (f"{e['planes']} planes {e['inliers']}/{e['size']} pts, {e['pixels']} px, "
                           f"{e['right'] / max(e['pixels'], 1):.2f} right") if e else "none"
            line.append(f"  region {reg}: default {f(d)} | after {f(a)}")
    print("\n".join(line))
for k, (r, p) in tot.items():
    print(f"{k}: {p} painted pixels, {r / max(p, 1):.3f} within 2%")
