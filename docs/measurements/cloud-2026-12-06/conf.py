import pickle, numpy as np, mvscope, sys
sys.path.insert(0, "/tmp/diag"); from png import write_png
from pathlib import Path
import os; room = Path(os.environ.get("ROOM", "/work/shared/data/rgbd/icl-livingroom")); D = os.environ.get("D", "/tmp/diag")
d = pickle.load(open(D + "/runs.pkl", "rb")); views = d["views"]
def gt_at(v):
    g = mvscope.read_pfm(room / "gt" / f"{v['si']:08d}.pfm"); H, W = g.shape
    ys = (np.arange(v["h"]) * H // v["h"]); xs = (np.arange(v["w"]) * W // v["w"])
    return g[ys][:, xs]
def unproj(v, dep):
    h, w = dep.shape; ys, xs = np.mgrid[0:h, 0:w]; K = v["K"]
    cam = np.stack([(xs - K[0, 2]) / K[0, 0] * dep, (ys - K[1, 2]) / K[1, 1] * dep, dep], -1)
    return (cam - v["t"]) @ v["R"]
def proj(v, X):
    cam = X @ v["R"].T + v["t"]; uv = cam @ v["K"].T
    return uv[..., 0] / uv[..., 2], uv[..., 1] / uv[..., 2], cam[..., 2]
def conf(meth):
    M = d["out"][meth]["maps"]; out = {}
    for v in views:
        i = v["index"]; dep = M[i]["depth"].astype(np.float64); nrm = M[i]["normal"].astype(np.float64)
        X = unproj(v, dep); cnt = np.zeros(dep.shape, int)
        for s in views:
            if s["index"] == i: continue
            j = s["index"]; dj = M[j]["depth"].astype(np.float64); nj = M[j]["normal"].astype(np.float64)
            u, vv, z = proj(s, X); qx = np.floor(u + 0.5).astype(int); qy = np.floor(vv + 0.5).astype(int)
            ok = (dep > 0) & (z > 0) & (qx >= 0) & (qx < s["w"]) & (qy >= 0) & (qy < s["h"])
            qx = np.clip(qx, 0, s["w"] - 1); qy = np.clip(qy, 0, s["h"] - 1)
            dq = dj[qy, qx]; ok &= dq > 0
            ok &= np.abs(z - dq) <= 0.01 * np.where(dq > 0, dq, 1)
            cosang = (nrm * nj[qy, qx]).sum(-1); ok &= cosang >= np.cos(np.radians(30))
            Xq = unproj(s, dj)[qy, qx]; u2, v2, _ = proj(v, Xq)
            ys, xs = np.mgrid[0:v["h"], 0:v["w"]]
            ok &= (u2 - xs) ** 2 + (v2 - ys) ** 2 <= 4.0
            cnt += ok
        out[i] = cnt
    return out
C = {m: conf(m) for m in ["acmm", "regions"]}
def errcol(dep, g):
    img = np.zeros(dep.shape + (3,), np.uint8) + 40
    e = np.abs(dep - g) / np.where(g > 0, g, 1); has = (g > 0) & (dep > 0)
    img[has & (e <= 0.01)] = (0, 200, 0); img[has & (e > 0.01) & (e <= 0.02)] = (150, 220, 0)
    img[has & (e > 0.02) & (e <= 0.05)] = (230, 180, 0); img[has & (e > 0.05)] = (220, 30, 30)
    return img
def confcol(c):
    img = np.zeros(c.shape + (3,), np.uint8) + 40; img[c == 1] = (90, 90, 200); img[c == 2] = (255, 255, 255); return img
rows = []
for v in views:
    g = gt_at(v); i = v["index"]
    r = [errcol(d["out"][m]["maps"][i]["depth"], g) for m in ["acmm", "regions"]] + [confcol(C[m][i]) for m in ["acmm", "regions"]]
    rows.append(np.concatenate(r, 1))
    for m in ["acmm", "regions"]:
        dep = d["out"][m]["maps"][i]["depth"]; has = (g > 0) & (dep > 0); e = np.abs(dep - g) / np.where(g > 0, g, 1)
        c = C[m][i]
        print(i, m, "w2 %.3f" % (e[has] <= 0.02).sum() / (g > 0).sum() if False else "", "w2 %.3f" % ((has & (e <= 0.02)).sum() / (g > 0).sum()),
              "conf2 %.3f" % (c == 2).mean(), "conf2&right %.3f" % ((c == 2) & has & (e <= 0.02)).sum() / max(1, (c == 2).sum()) if False else "",
              "conf>=1 %.3f" % (c >= 1).mean(), "prec2 %.3f" % (((c == 2) & has & (e <= 0.02)).sum() / max(1, ((c == 2) & (g > 0)).sum())))
write_png(D + "/conf.png", np.concatenate(rows, 0))
pickle.dump(C, open(D + "/conf.pkl", "wb"))
