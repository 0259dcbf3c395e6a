"""Registered ICL / kitchen-a: Regions' wrong priors by source (region plane, triangle), and how their
pixels end against ACMM."""
import pathlib, sys, warnings
import numpy as np, mvscope
room = pathlib.Path(sys.argv[1])
scene = open_scene(room)
from PIL import Image
from common import KITCHEN_A, at_prior_end, open_scene, rs
s = at_prior_end(scene)
info = []
for v in scene.views:
    m, mesh = s.maps(v.index), s.prior_mesh(v.index); H, W = m.height, m.width
    g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
    w = room / "gt" / f"{v.scene_index:08d}_lowtex.png"
    wk = (rs(np.asarray(Image.open(w)) > 0, (H, W)) if w.exists() else np.zeros((H, W), bool)) & (g > 0)
    r = mesh["regions"]; c = r["cell"]
    plane = r["plane"][np.arange(H)[:, None] // c, np.arange(W) // c]
    pr = m["prior_depth"]
    right = (pr > 0) & (np.abs(pr - g) <= 0.02 * g)
    info.append(dict(g=g, wk=wk, reg_right=right & (plane >= 0), reg_wrong=(pr > 0) & ~right & (plane >= 0),
                     tri_right=right & (plane < 0), tri_wrong=(pr > 0) & ~right & (plane < 0), none=(pr <= 0) & (g > 0)))
s.run()
a = mvscope.Session(scene, method="acmm", seed=0); a.run()
print(f"{'weak pixels':<14}{'share':>7}{'ACMM':>7}{'Regions':>9}   (within 2% at the end; share of weak px)")
tot = {}
for v, d in zip(scene.views, info):
    g = d["g"]
    okr = np.abs(s.depth(v.index) - g) <= 0.02 * g; oka = np.abs(a.depth(v.index) - g) <= 0.02 * g
    for k in ("reg_right", "reg_wrong", "tri_right", "tri_wrong", "none"):
        mk = d[k] & d["wk"]
        t = tot.setdefault(k, np.zeros(3)); t += [mk.sum(), (mk & oka).sum(), (mk & okr).sum()]
allw = sum(t[0] for t in tot.values())
for k, t in tot.items():
    print(f"{k:<14}{100*t[0]/allw:7.1f}{100*t[1]/max(t[0],1):7.1f}{100*t[2]/max(t[0],1):9.1f}")
