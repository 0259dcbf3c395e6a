# The photometric contrast of each finest-scale region plane: the matching cost of its
# painted pixels (every second pixel) at the plane and at the plane moved 2% and 4% nearer
# and farther along the rays, computed here in numpy (NCC of an 11x11 window, every second
# sample, through the plane's homography into each source, 1 - NCC, the mean of the two best
# sources), not by the tool's kernel. Usage: contrast.py SCENE [NAME=VALUE...]
import sys, pathlib, warnings, numpy as np
from PIL import Image
import mvscope
room = pathlib.Path(sys.argv[1]); sets = sys.argv[2:]
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0, params={k: v for k, v in (a.split("=") for a in sets)})
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
def cam(i):
    t = (room / "cams" / f"{i:08d}_cam.txt").read_text().split()
    return np.array(t[1:17], float).reshape(4, 4), np.array(t[18:27], float).reshape(3, 3)
pairs = (room / "pair.txt").read_text().split("\n")
imgs = sorted((room / "images").iterdir())
def gray(i, w):
    a = np.asarray(Image.open(imgs[i]).convert("RGB"), float)
    g = a @ [0.299, 0.587, 0.114]
    if g.shape[1] != w:
        g = np.asarray(Image.fromarray(g.astype(np.float32)).resize((w, round(g.shape[0] * w / g.shape[1])), Image.BILINEAR), float)
    return g
def bilinear(g, u, v):
    h, w = g.shape
    ok = (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1)
    u = np.clip(u, 0, w - 1.001); v = np.clip(v, 0, h - 1.001)
    x0, y0 = np.floor(u).astype(int), np.floor(v).astype(int); fx, fy = u - x0, v - y0
    val = g[y0, x0] * (1 - fx) * (1 - fy) + g[y0, x0 + 1] * fx * (1 - fy) + g[y0 + 1, x0] * (1 - fx) * fy + g[y0 + 1, x0 + 1] * fx * fy
    return val, ok
off = np.array([(dx, dy) for dy in range(-5, 6, 2) for dx in range(-5, 6, 2)], float)
shifts = [-0.04, -0.02, 0.0, 0.02, 0.04]
print("settings:", " ".join(sets) or "defaults", "| shifts", shifts)
for v in scene.views:
    i = v.scene_index
    m, mesh = s.maps(v.index), s.prior_mesh(v.index)
    W, H = m.width, m.height
    g0 = gray(i, W); sc = W / g0.shape[1] if False else 1.0
    E, K = cam(i)
    gtf = mvscope.read_pfm(room / "gt" / f"{i:08d}.pfm"); kscale = W / gtf.shape[1]
    K = K.copy(); K[:2] *= kscale
    gt = gtf[np.ix_(np.clip(np.floor((np.arange(H) + 0.5) / kscale), 0, gtf.shape[0] - 1).astype(int), np.clip(np.floor((np.arange(W) + 0.5) / kscale), 0, gtf.shape[1] - 1).astype(int))]
    srcs = [int(a) for a in pairs[2 + 2 * i].split()[1::2]]
    src = []
    for j in srcs:
        Es, Ks = cam(j); Ks = Ks.copy(); Ks[:2] *= kscale
        rel = Es @ np.linalg.inv(E)
        src.append((gray(j, W), Ks, rel[:3, :3], rel[:3, 3]))
    r = mesh["regions"]; c = r["cell"]
    plane_px = r["plane"][np.arange(H)[:, None] // c, np.arange(W) // c]
    prior = m["prior_depth"]; right = (prior > 0) & (gt > 0) & (np.abs(prior - gt) <= 0.02 * gt)
    Kinv = np.linalg.inv(K)
    print(f"view {v.index}:")
    for k, pl in enumerate(r["planes"]):
        ys, xs = np.nonzero((plane_px == k) & (prior > 0))
        if len(xs) < 100: continue
        rt = right[ys, xs].mean()
        sel = (xs % 2 == 0) & (ys % 2 == 0) & (xs >= 5) & (ys >= 5) & (xs < W - 5) & (ys < H - 5)
        xs, ys = xs[sel], ys[sel]
        qx = xs[:, None] + off[None, :, 0]; qy = ys[:, None] + off[None, :, 1]
        ref = g0[qy.astype(int), qx.astype(int)]
        n = np.asarray(pl["plane"], float)
        rays = np.stack([qx, qy, np.ones_like(qx)], -1) @ Kinv.T
        med = []
        costs = []
        for sh in shifts:
            dep = -n[3] * (1 + sh) / (rays @ n[:3])
            X = rays * dep[..., None]
            per = []
            for gs, Ks, R, t in src:
                Y = X @ R.T + t; uvw = Y @ Ks.T
                u, vv = uvw[..., 0] / uvw[..., 2], uvw[..., 1] / uvw[..., 2]
                val, ok = bilinear(gs, u, vv)
                a = ref - ref.mean(1, keepdims=True); b = val - val.mean(1, keepdims=True)
                ncc = (a * b).sum(1) / np.sqrt((a * a).sum(1) * (b * b).sum(1) + 1e-9)
                cst = np.where(ok.all(1) & (Y[..., 2] > 0).all(1), 1 - ncc, 2.0)
                per.append(cst)
            per = np.sort(np.stack(per, 1), 1)
            costs.append(per[:, :2].mean(1))
        costs = np.stack(costs, 1)
        meds = np.median(costs, 0)
        best = np.argmin(costs, 1)
        print(f"   plane {k:2d}: pixels {len(xs):4d} (sampled), prior right {rt:4.2f}; median cost at " +
              " ".join(f"{sh:+.0%} {mv:.3f}" for sh, mv in zip(shifts, meds)) +
              f"; plane's own the lowest of the five on {np.mean(best == 2):.2f}")
