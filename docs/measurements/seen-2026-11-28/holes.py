"""Registered ICL: where the weak pixels without a prior (Regions defaults) lie and why, per view;
their final error under Regions; a picture per view."""
import pathlib, sys
import numpy as np, mvscope
from PIL import Image
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "reach-2026-11-28"))  # common.py
from common import at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1])
scene = open_scene(room)
s = at_prior_end(scene)
info = []
for v in scene.views:
    m, mesh = s.maps(v.index), s.prior_mesh(v.index); H, W = m.height, m.width
    g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
    w = room / "gt" / f"{v.scene_index:08d}_lowtex.png"
    wk = (rs(np.asarray(Image.open(w)) > 0, (H, W)) if w.exists() else np.zeros((H, W), bool)) & (g > 0)
    r = mesh["regions"]; c = r["cell"]
    reg = r["region"][np.arange(H)[:, None] // c, np.arange(W) // c]
    plane = r["plane"][np.arange(H)[:, None] // c, np.arange(W) // c]
    pr = m["prior_depth"]
    none = (pr <= 0) & wk
    info.append((v, g, wk, none, reg, plane, pr, m["depth"].copy()))
s.run()
for v, g, wk, none, reg, plane, pr, d0 in info:
    d = s.depth(v.index); ok = np.abs(d - g) <= 0.02 * g
    H, W = g.shape
    print(f"view {v.index}: weak {wk.sum()}, no prior {none.sum()} ({100*none.sum()/wk.sum():.1f}%), end right {100*(ok&none).sum()/max(none.sum(),1):.1f}%; "
          f"in flat region {(none & (reg>0)).sum()}, region w/o plane {(none&(reg>0)&(plane<0)).sum()}, code {np.unique(pr[none].round(0))[:6]}")
    img = np.zeros((H, W, 3), np.uint8)
    img[wk] = (60, 60, 60); img[wk & ok] = (0, 120, 0)
    img[none & ok] = (0, 255, 0); img[none & ~ok] = (255, 0, 0)
    Image.fromarray(img).resize((W * 2, H * 2), Image.NEAREST).save(f"holes-{v.index}.png")
