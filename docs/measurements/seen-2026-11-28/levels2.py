"""Registered ICL view V: at the end of every scale's prior stage, the weak pixels of the finest
scale's plane-less flat regions (and those whose plane leaves the range): points there, prior right."""
import pathlib, sys
import numpy as np, mvscope
from PIL import Image
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "reach-2026-11-28"))  # common.py
from common import at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1]); vi = int(sys.argv[2])
scene = open_scene(room)
s = at_prior_end(scene)
v = scene.views[vi]
m, mesh = s.maps(vi), s.prior_mesh(vi); H, W = m.height, m.width
g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
w = room / "gt" / f"{v.scene_index:08d}_lowtex.png"
wk = rs(np.asarray(Image.open(w)) > 0, (H, W)) & (g > 0)
r = mesh["regions"]; c = r["cell"]
reg = r["region"][np.arange(H)[:, None] // c, np.arange(W) // c]
plane = r["plane"][np.arange(H)[:, None] // c, np.arange(W) // c]
hole = wk & (m["prior_depth"] <= 0)
print("finest: hole px", hole.sum(), "in flat regions w/o plane", (hole & (reg > 0) & (plane < 0)).sum(), "out of range", (hole & (plane >= 0)).sum())
for lvl in range(s.num_levels):
    st = max(x["index"] for x in s.steps if (x["level"], x["stage"]) == (lvl, "planar prior"))
    s.goto(st + 1)
    mm = s.maps(vi); me = s.prior_mesh(vi); h, wd = mm.height, mm.width
    pr = rs(mm["prior_depth"], (H, W)); dep = rs(mm["depth"], (H, W))
    P = me["points"] if me else np.zeros((0, 2), int)
    # points of this level falling in the finest hole pixels
    sx, sy = W / wd, H / h
    ph = hole[np.clip((P[:, 1] * sy).astype(int), 0, H - 1), np.clip((P[:, 0] * sx).astype(int), 0, W - 1)] if len(P) else np.zeros(0, bool)
    ok = (pr > 0) & (np.abs(pr - g) <= 0.02 * g)
    print(f"level {lvl} {wd}x{h}: points {len(P)}, in holes {ph.sum()}; hole px with prior {100*((pr>0)&hole).sum()/hole.sum():.1f}%, prior right {100*(ok&hole).sum()/hole.sum():.1f}%, "
          f"depth right {100*((np.abs(dep-g)<=0.02*g)&hole).sum()/hole.sum():.1f}%; regions planes {len(me['regions']['planes']) if me and me.get('regions') else None}")
