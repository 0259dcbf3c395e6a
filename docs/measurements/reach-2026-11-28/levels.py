"""Kitchen-a: the red cabinet front (the largest flat region without a plane at the finest scale):
how right its depths and support points are at each scale and stage."""
import pathlib, sys, warnings
import numpy as np, mvscope
from PIL import Image
from common import KITCHEN_A, at_prior_end, open_scene, rs
room = KITCHEN_A
scene = open_scene(room)
method = sys.argv[1] if len(sys.argv) > 1 else "regions"
gt = [mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm") for v in scene.views]
s = at_prior_end(scene)
masks = []
for v in scene.views:
    R = s.prior_mesh(v.index)["regions"]; c = R["cell"]; H, W = s.maps(v.index).height, s.maps(v.index).width
    yy, xx = np.mgrid[0:H, 0:W]; reg = R["region"][yy // c, xx // c]
    masks.append(reg == np.bincount(reg.ravel())[1:].argmax() + 1)
if method != "regions":
    s = mvscope.Session(scene, method=method, seed=0)
ends = {}
for st in s.steps:
    ends[(st["level"], st["stage"])] = st["index"] + 1
rng = np.random.default_rng(0)
for (lvl, stage), cur in sorted(ends.items(), key=lambda i: i[1]):
    s.goto(cur)
    a2 = a5 = n = 0; p2 = p5 = pn = 0; shares = []
    for v in scene.views:
        if v.index == 7: continue
        m = s.maps(v.index); H, W = m.height, m.width
        g = rs(gt[v.index], (H, W)); mk = rs(masks[v.index], (H, W)) & (g > 0)
        d = m["depth"]
        a2 += ((np.abs(d - g) <= 0.02 * g) & mk).sum(); a5 += ((np.abs(d - g) <= 0.05 * g) & mk).sum(); n += mk.sum()
        if stage == "planar prior":
            mesh = s.prior_mesh(v.index); P = mesh["points"]; pd = mesh["point_depth"]
            inm = mk[P[:, 1], P[:, 0]]; gp = g[P[:, 1], P[:, 0]]
            p2 += (inm & (np.abs(pd - gp) <= 0.02 * gp)).sum(); p5 += (inm & (np.abs(pd - gp) <= 0.05 * gp)).sum(); pn += inm.sum()
    extra = f"  points {pn:4d} right 2% {100*p2/max(pn,1):5.1f} 5% {100*p5/max(pn,1):5.1f}" if pn else ""
    print(f"level {lvl} {stage:<22} cabinet within 2% {100*a2/n:5.1f} 5% {100*a5/n:5.1f}{extra}", flush=True)
