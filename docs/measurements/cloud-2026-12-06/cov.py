import pickle, numpy as np, mvscope
from pathlib import Path
import os; room = Path(os.environ.get("ROOM", "/work/shared/data/rgbd/icl-livingroom")); D = os.environ.get("D", "/tmp/diag")
d = pickle.load(open(D + "/runs.pkl", "rb"))
views = d["views"]
# truth cloud at full res, 1 cm voxels, remember origin (view, x, y) at processed size
pts, org = [], []
seen = set()
for v in views:
    gt = mvscope.read_pfm(room / "gt" / f"{v['si']:08d}.pfm")
    H, W = gt.shape
    K = v["K"].copy(); sx = W / v["w"]; sy = H / v["h"]
    # rescale camera: pixel centres on integers
    K2 = K.copy(); K2[0, 0] *= sx; K2[1, 1] *= sy; K2[0, 2] = (K[0, 2] + 0.5) * sx - 0.5; K2[1, 2] = (K[1, 2] + 0.5) * sy - 0.5
    ys, xs = np.nonzero(gt > 0)
    z = gt[ys, xs]
    cam = np.stack([(xs - K2[0, 2]) / K2[0, 0] * z, (ys - K2[1, 2]) / K2[1, 1] * z, z], 1)
    X = (cam - v["t"]) @ v["R"]  # R^T (cam - t)
    keys = np.floor(X / 0.01).astype(np.int64)
    for i in range(len(X)):
        k = tuple(keys[i])
        if k not in seen:
            seen.add(k); pts.append(X[i]); org.append((v["index"], int(xs[i] / sx), int(ys[i] / sy)))
pts = np.array(pts); org = np.array(org)
print("truth points", len(pts))
def near(a, b, r):
    out = np.zeros(len(a), bool)
    c = max(1, int(2e7 // len(b)))
    for i in range(0, len(a), c):
        dd = ((a[i:i+c, None, :] - b[None, :, :]) ** 2).sum(-1)
        out[i:i+c] = dd.min(1) <= r * r
    return out
cov = {}
for m in ["acmm", "regions"]:
    P = d["out"][m]["points"].astype(np.float64)
    cov[m] = near(pts, P, 0.05)
    acc = near(P, pts, 0.05).mean()
    print(m, "points", len(P), "acc", round(acc, 4), "comp", round(cov[m].mean(), 4))
a, r = cov["acmm"], cov["regions"]
print("both", (a & r).sum(), "acmm only", (a & ~r).sum(), "regions only", (~a & r).sum(), "neither", (~a & ~r).sum())
np.savez(D + "/cov.npz", pts=pts, org=org, a=a, r=r)
for vi in range(3):
    sel = org[:, 0] == vi
    print("view", vi, "truth pts", sel.sum(), "acmm only", (a & ~r & sel).sum(), "regions only", (~a & r & sel).sum(), "both", (a & r & sel).sum())
