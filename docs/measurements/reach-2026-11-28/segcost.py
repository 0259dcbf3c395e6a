"""Does a whole region's photometric cost find its plane? Kitchen-a cabinet: cost of the truth plane
scaled in depth, aggregated over the region (dilated by the window) with plane-induced warps."""
import pathlib, sys, warnings
import numpy as np, mvscope
from common import KITCHEN_A, at_prior_end, open_scene, rs

def uniform_filter(a, k):
    r = k // 2
    p = np.pad(a, r, mode="edge")
    c = np.cumsum(np.cumsum(p, 0), 1); c = np.pad(c, ((1, 0), (1, 0)))
    H, W = a.shape
    return (c[k:k+H, k:k+W] - c[0:H, k:k+W] - c[k:k+H, 0:W] + c[0:H, 0:W]) / (k * k)
def binary_dilation(m, iterations):
    return uniform_filter(m.astype(float), 2 * iterations + 1) > 1e-9
def map_coordinates(img, yx, order=1, mode="nearest"):
    y, x = yx; H, W = img.shape
    x = np.clip(x, 0, W - 1.001); y = np.clip(y, 0, H - 1.001)
    x0 = np.floor(x).astype(int); y0 = np.floor(y).astype(int); fx = x - x0; fy = y - y0
    return (img[y0, x0] * (1 - fx) * (1 - fy) + img[y0, x0 + 1] * fx * (1 - fy)
            + img[y0 + 1, x0] * (1 - fx) * fy + img[y0 + 1, x0 + 1] * fx * fy)
room = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else KITCHEN_A)
scene = open_scene(room)
s = at_prior_end(scene)
r = 5
import os; CHECK = os.environ.get('CHECK') == '1'
for vi in [int(a) for a in sys.argv[2:]] or [0, 3, 5]:
    v = scene.views[vi]; mesh = s.prior_mesh(vi); H, W = v.height, v.width
    g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
    R = mesh["regions"]; c = R["cell"]; yy, xx = np.mgrid[0:H, 0:W]; reg = R["region"][yy // c, xx // c]
    big = np.bincount(reg.ravel())[1:].argmax() + 1; mk = reg == big
    K = v.K; U = (xx - K[0, 2]) / K[0, 0]; V = (yy - K[1, 2]) / K[1, 1]
    sel = mk & (g > 0)
    A = np.c_[U[sel], V[sel], np.ones(sel.sum())]
    abc = np.linalg.lstsq(A, 1 / g[sel], rcond=None)[0]
    e = np.abs(1 / (A @ abc) - g[sel]) / g[sel]
    ref = v.gray().astype(float)
    area = binary_dilation(mk, iterations=r)
    m0 = uniform_filter(ref, 2 * r + 1); sd0 = np.sqrt(np.maximum(uniform_filter(ref * ref, 2 * r + 1) - m0 * m0, 0))
    use = area & (sd0 > 2.0)
    line = f"view {vi} truth plane fits region: {100*(e<=0.02).mean():.0f}% within 2%; textured px used {use.sum()} of {area.sum()} |"
    for scale in (0.85, 0.9, 0.94, 0.97, 0.99, 1.0, 1.01, 1.03, 1.06, 1.1, 1.15):
        inv = (abc[0] * U + abc[1] * V + abc[2]) / scale
        d = 1 / np.maximum(inv, 1e-6)
        if CHECK: d = np.where(g > 0, g * scale, d); use = (g > 0) & (sd0 > 10) & ~area
        Xc = np.stack([U * d, V * d, d], -1)
        costs = []
        for src in v.sources[:6]:
            o = scene.views[src.view]
            Xw = (Xc - v.t) @ v.R  # R^T (X - t)
            Xo = Xw @ o.R.T + o.t
            px = Xo @ o.K.T
            sx, sy = px[..., 0] / px[..., 2], px[..., 1] / px[..., 2]
            warped = map_coordinates(o.gray().astype(float), [sy, sx], order=1, mode="nearest")
            m1 = uniform_filter(warped, 2 * r + 1)
            cov = uniform_filter(ref * warped, 2 * r + 1) - m0 * m1
            sd1 = np.sqrt(np.maximum(uniform_filter(warped * warped, 2 * r + 1) - m1 * m1, 0))
            ncc = cov / np.maximum(sd0 * sd1, 1e-6)
            costs.append(1 - ncc)
        costs = np.sort(np.stack(costs), 0)[:3].mean(0)  # best 3 of 6 per pixel
        line += f" {scale:.2f}:{costs[use].mean():.3f}"
    print(line, flush=True)
