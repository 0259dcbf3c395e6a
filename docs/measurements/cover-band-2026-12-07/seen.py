# Which sources see a block of a view's truth surface: each pixel's true 3-d point projected
# into every source, seen where it falls inside the source's image and the source's true depth
# there agrees within 1% (not occluded). Numpy over the scene's own cams and gt/.
import sys, pathlib, numpy as np
import mvscope
room = pathlib.Path(sys.argv[1]); v = int(sys.argv[2]); x0, x1, y0, y1 = map(int, sys.argv[3:7])
def cam(i):
    t = (room / "cams" / f"{i:08d}_cam.txt").read_text().split()
    e = np.array(t[1:17], float).reshape(4, 4); k = np.array(t[18:27], float).reshape(3, 3)
    return e, k
gt = {i: mvscope.read_pfm(room / "gt" / f"{i:08d}.pfm") for i in range(5)}
weak = np.asarray(__import__("PIL.Image", fromlist=["Image"]).open(room / "gt" / f"{v:08d}_lowtex.png")) > 0
E, K = cam(v)
srcs = [int(a) for a in (room / "pair.txt").read_text().split("\n")[2 + 2 * v].split()[1::2]]
d = gt[v][y0:y1, x0:x1]; ys, xs = np.mgrid[y0:y1, x0:x1]
m = (d > 0) & weak[y0:y1, x0:x1]
pc = np.linalg.inv(K) @ np.stack([xs[m], ys[m], np.ones(m.sum())]) * d[m]
pw = np.linalg.inv(E) @ np.vstack([pc, np.ones(m.sum())])
seen = np.zeros(m.sum(), int)
for s in srcs:
    Es, Ks = cam(s); q = Es @ pw; z = q[2]; uv = Ks @ q[:3]; u, w_ = uv[0] / uv[2], uv[1] / uv[2]
    H, W = gt[s].shape
    inside = (z > 0) & (u >= 0) & (u < W - 0.5) & (w_ >= 0) & (w_ < H - 0.5)
    ds = np.zeros_like(z); ui = np.clip(np.round(u).astype(int), 0, W - 1); vi = np.clip(np.round(w_).astype(int), 0, H - 1)
    ds[inside] = gt[s][vi[inside], ui[inside]]
    vis = inside & (np.abs(ds - z) <= 0.01 * z)
    occl = inside & (ds < z * 0.99)
    print(f"source {s}: inside {inside.mean():.2f}, seen {vis.mean():.2f}, occluded {occl.mean():.2f}")
    seen += vis
print(f"view {v} block x {x0}-{x1} y {y0}-{y1}: {m.sum()} weak pixels; seen by 0/1/2+ sources: "
      f"{(seen==0).mean():.2f} / {(seen==1).mean():.2f} / {(seen>=2).mean():.2f}")
