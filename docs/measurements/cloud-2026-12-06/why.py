import pickle, numpy as np, mvscope, sys
sys.path.insert(0, "/tmp/diag"); exec(open("/tmp/diag/conf.py").read().split("C = {m")[0])
C = pickle.load(open(D + "/conf.pkl", "rb"))
c = np.load(D + "/cov.npz"); pts, org, a, r = c["pts"], c["org"], c["a"], c["r"]
G = {v["index"]: gt_at(v) for v in views}
# for each truth point and view: visible pixel, conf and err of each method
info = {m: np.full((len(pts), 3, 2), np.nan) for m in ["acmm", "regions"]}
for v in views:
    i = v["index"]; u, vv, z = proj(v, pts); x = np.floor(u + .5).astype(int); y = np.floor(vv + .5).astype(int)
    ok = (z > 0) & (x >= 0) & (x < v["w"]) & (y >= 0) & (y < v["h"]); x = np.clip(x, 0, v["w"]-1); y = np.clip(y, 0, v["h"]-1)
    g = G[i][y, x]; ok &= (g > 0) & (np.abs(g - z) < 0.03 * z)
    for m in ["acmm", "regions"]:
        dep = d["out"][m]["maps"][i]["depth"][y, x]
        e = np.where(dep > 0, np.abs(dep - z) / z, 9)
        info[m][:, i, 0] = np.where(ok, C[m][i][y, x], np.nan); info[m][:, i, 1] = np.where(ok, e, np.nan)
def summary(sel, name):
    print(f"--- {name}: {sel.sum()} truth points")
    for m in ["acmm", "regions"]:
        mc = np.nanmax(info[m][sel, :, 0], 1); me = np.nanmin(info[m][sel, :, 1], 1)
        vis = (~np.isnan(info[m][sel, :, 0])).sum(1)
        print(f"  {m}: views seeing it {np.bincount(vis, minlength=4)}, max conf {np.bincount(np.nan_to_num(mc, nan=-1).astype(int)+1, minlength=4)} (-1,0,1,2), best err<=1% {np.mean(me<=.01):.2f} <=2% {np.mean(me<=.02):.2f} <=5% {np.mean(me<=.05):.2f}")
summary(a & ~r, "ACMM only"); summary(~a & r, "Regions only"); summary(a & r, "both")
