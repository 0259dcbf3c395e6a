import pathlib, warnings, numpy as np, mvscope
from common import KITCHEN_A, at_prior_end, open_scene, rs
room = KITCHEN_A
scene = open_scene(room)
v = scene.views[3]; o = scene.views[v.sources[0].view]
print(v.width, v.height, v.K, o.K, sep="\n")
g = mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"); print("gt shape", g.shape)
ref = v.gray(); src = o.gray()
for (x, y) in [(100, 170), (200, 150), (60, 40)]:
    d = g[2*y, 2*x]
    X = np.linalg.inv(v.K) @ [x, y, 1] * d
    Xw = v.R.T @ (X - v.t); Xo = o.R @ Xw + o.t; p = o.K @ Xo; p = p[:2] / p[2]
    a = ref[y-5:y+6, x-5:x+6].ravel()
    best = []
    for dy in range(-6, 7):
        for dx in range(-6, 7):
            xx, yy = int(round(p[0])) + dx, int(round(p[1])) + dy
            b = src[yy-5:yy+6, xx-5:xx+6].ravel()
            if b.size != a.size: continue
            n = np.corrcoef(a, b)[0, 1]; best.append((n, dx, dy))
    best.sort(reverse=True); print((x, y), "d", d, "proj", p.round(1), "best offset", best[0])
