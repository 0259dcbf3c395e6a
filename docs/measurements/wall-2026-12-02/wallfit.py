"""What the wall scripts share: reading one view's largest flat region from dump.py's .npz,
and the least-absolute-deviation fit they compare."""
import numpy as np


def lad(A, y, iters=50):
    """x minimising the summed |A x - y| (iteratively reweighted least squares)."""
    w = np.ones(len(y))
    for _ in range(iters):
        x, *_ = np.linalg.lstsq(A * w[:, None], y * w, rcond=None)
        w = 1 / np.sqrt(np.maximum(np.abs(A @ x - y), 1e-6))
    return x


def largest_region(z, v):
    """View v's largest flat region: its pixels with truth (mask at the maps' size), their
    rays K^-1 (x, y, 1) and truth depths, the truth's plane normal over them (camera
    frame), and the region's support points' rays and depths."""
    g = lambda k: z[f"{v}_{k}"]
    gt, reg, c, K = g("gt"), g("region"), int(g("cell")), g("K")
    big = int(np.argmax(g("sizes"))) + 1
    h, w = gt.shape
    ys, xs = np.mgrid[0:h, 0:w]
    inreg = (reg[ys // c, xs // c] == big) & (gt > 0)
    Ki = np.linalg.inv(K)
    rays = Ki @ np.stack([xs[inreg], ys[inreg], np.ones(inreg.sum())])
    Xc = (rays * gt[inreg]).T
    cen = Xc.mean(0)
    n = np.linalg.eigh((Xc - cen).T @ (Xc - cen))[1][:, 0]
    p, dep = g("points"), g("point_depth")
    pin = (reg[p[:, 1] // c, p[:, 0] // c] == big) & (dep > 0)
    pr = Ki @ np.stack([p[pin, 0], p[pin, 1], np.ones(pin.sum())])
    return {"mask": inreg, "rays": rays, "gt": gt[inreg], "normal": n,
            "point_rays": pr, "point_depth": dep[pin]}
