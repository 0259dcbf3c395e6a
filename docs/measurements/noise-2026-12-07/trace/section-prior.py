import sys, pathlib, warnings, numpy as np
import mvscope
room = pathlib.Path(sys.argv[1]); vi = int(sys.argv[2]); x0, x1, y0, y1 = map(int, sys.argv[3].split(',')); LEVEL = int(sys.argv[4]); sets = sys.argv[5:]
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0, params={k: v for k, v in (a.split("=") for a in sets)})
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (LEVEL, "planar prior")) + 1)
v = scene.views[vi]; gt0 = mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm")
m, mesh = s.maps(vi), s.prior_mesh(vi)
H0, W0 = gt0.shape; hh, ww = m.height, m.width
gt = gt0[np.ix_(np.clip(np.floor((np.arange(hh) + 0.5) * H0 / hh), 0, H0 - 1).astype(int), np.clip(np.floor((np.arange(ww) + 0.5) * W0 / ww), 0, W0 - 1).astype(int))]
f = ww / 320; sl = (slice(int(y0 * f), int(y1 * f)), slice(int(x0 * f), int(x1 * f)))
r = mesh["regions"]; rows, cols = np.arange(hh)[:, None] // r["cell"], np.arange(ww) // r["cell"]
region, plane = r["region"][rows, cols][sl], r["plane"][rows, cols][sl]
prior = m["prior_depth"][sl]; g = gt[sl]
e = np.abs(prior - g) / g
print(f"level {LEVEL} ({ww}x{hh}) section pixels {prior.size}: prior within 2% {np.mean((prior > 0) & (e < 0.02)):.3f}, prior wrong {np.mean((prior > 0) & (e >= 0.02)):.3f}, none {np.mean(prior <= 0):.3f}; in a flat region {np.mean(region > 0):.3f}, with a region plane {np.mean(plane >= 0):.3f}")
for k in np.unique(region[region > 0]):
    sel = region == k
    pl = np.unique(plane[sel])
    print(f"  region {k}: {sel.sum()} px here, size {r['sizes'][k-1]} points, planes {pl.tolist()}, prior within 2% {np.mean((prior[sel] > 0) & (e[sel] < 0.02)):.2f}, median signed {np.median(((prior[sel] - g[sel]) / g[sel])[prior[sel] > 0]) if (prior[sel] > 0).any() else float('nan'):+.4f}")
sel = region == 0
print(f"  not flat: {sel.sum()} px, prior within 2% {np.mean((prior[sel] > 0) & (e[sel] < 0.02)):.2f}, wrong {np.mean((prior[sel] > 0) & (e[sel] >= 0.02)):.2f}")
