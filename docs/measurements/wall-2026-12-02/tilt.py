"""Reads dump.py's .npz. Each view's largest flat region: its own least-absolute fit in 1/d
against the truth's plane over the region (their depth ratio, 5th/50th/95th percentile), the
truth's tilt with the points' fitted offset, and how much a cell's error correlates with its
right neighbour's (blotches or noise)."""
import numpy as np
from wallfit import lad
z = np.load("/tmp/wall-dump.npz")
for v in range(int(z["views"])):
    g = lambda k: z[f"{v}_{k}"]
    gt, reg, c, K = g("gt"), g("region"), int(g("cell")), g("K")
    big = int(np.argmax(g("sizes"))) + 1
    h, w = gt.shape; ys, xs = np.mgrid[0:h, 0:w]
    nu = lambda x: (x - K[0, 2]) / K[0, 0]; nv = lambda y: (y - K[1, 2]) / K[1, 1]
    inreg = (reg[ys // c, xs // c] == big) & (gt > 0)
    A = np.stack([nu(xs[inreg]), nv(ys[inreg]), np.ones(inreg.sum())], 1)
    tp, *_ = np.linalg.lstsq(A, 1 / gt[inreg], rcond=None)
    p, dep = g("points"), g("point_depth")
    pin = (reg[p[:, 1] // c, p[:, 0] // c] == big) & (dep > 0)
    P = np.stack([nu(p[pin, 0]), nv(p[pin, 1]), np.ones(pin.sum())], 1)
    fit = lad(P, 1 / dep[pin])
    ratio = (A @ tp) / (A @ fit)   # fitted depth / truth plane depth
    # offset-only: truth's slope, LAD offset
    off = np.median(1/dep[pin] - P[:, :2] @ tp[:2])
    fo = np.r_[tp[:2], off]
    held_o = np.mean(np.abs(1/(A@fo) - gt[inreg]) <= 0.02*gt[inreg])
    # spatial correlation of errors: points' error vs 4-neighbour cell's error
    err = dep[pin] * (P @ tp) - 1
    cells = {(int(q[1])//c, int(q[0])//c): e for q, e in zip(p[pin], err)}
    pairs = [(e, cells[(cy, cx+1)]) for (cy, cx), e in cells.items() if (cy, cx+1) in cells]
    pr = np.corrcoef(np.array(pairs).T)[0, 1]
    print(f"view {v}: fitted/truth plane depth over region p5/p50/p95 {np.percentile(ratio,5):.3f}/{np.median(ratio):.3f}/{np.percentile(ratio,95):.3f}; truth slope + LAD offset holds {100*held_o:.0f}%; neighbour cells' error correlation {pr:.2f}; region bbox x {p[pin,0].min()}-{p[pin,0].max()} y {p[pin,1].min()}-{p[pin,1].max()}")
