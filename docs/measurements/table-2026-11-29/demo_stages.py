import sys, warnings, pathlib
import numpy as np
import mvscope
warnings.simplefilter("ignore")
out = pathlib.Path("/tmp/s25/bimodal/scene")
scene = mvscope.demo(out, views=5, width=320, height=240, seed=1) if not out.exists() else mvscope.Scene.open(out)

def resized(a, shape):
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0]), 0, a.shape[0] - 1).astype(int)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1]), 0, a.shape[1] - 1).astype(int)
    return a[np.ix_(rows, cols)]

import matplotlib.pyplot as plt
gts = [mvscope.read_pfm(out / "gt" / f"{v.scene_index:08d}.pfm") for v in scene.views]
lows = [plt.imread(out / "gt" / f"{v.scene_index:08d}_lowtex.png") > 0 for v in scene.views]
seed = int(sys.argv[1])
s = mvscope.Session(scene, method="regions", seed=seed)
groups = {}
for st in s.steps:
    groups.setdefault((st["level"], st["stage"]), st["index"])
    groups[(st["level"], st["stage"])] = st["index"]
res = {}
for key, last in sorted(groups.items(), key=lambda kv: kv[1]):
    s.goto(last + 1)
    row = []
    for v in scene.views:
        d = s.depth(v.index)
        g = resized(gts[v.index], d.shape); w = resized(lows[v.index], d.shape) & (g > 0)
        ok = np.abs(d - g) <= 0.02 * g
        row.append((100 * ok[g > 0].mean(), 100 * ok[w].mean()))
    print(f"seed {seed} L{key[0]} {key[1]:<16}", " ".join(f"{a:5.1f}/{b:5.1f}" for a, b in row),
          f"| mean {np.mean([r[0] for r in row]):5.1f} weak {np.mean([r[1] for r in row]):5.1f}", flush=True)
    if key[1] == "planar prior":
        for v in scene.views:
            m = s.maps(v.index); mesh = s.prior_mesh(v.index)
            g = resized(gts[v.index], (m.height, m.width)); w = resized(lows[v.index], g.shape) & (g > 0)
            p = m["prior_depth"]
            right = (p > 0) & (np.abs(p - g) <= 0.02 * g)
            r = mesh["regions"]
            print(f"   v{v.index} pts {len(mesh['points'])} regions {r['region'].max()} planes {len(r['planes'])} "
                  f"weak with prior {100*((p>0)&w).sum()/w.sum():5.1f} right {100*(right&w).sum()/w.sum():5.1f}", flush=True)
