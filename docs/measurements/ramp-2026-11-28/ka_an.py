import pickle, pathlib, sys
import numpy as np
import mvscope
from PIL import Image
room = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/s16/k526/rgbd/kitchen-a")
pk = sys.argv[2] if len(sys.argv) > 2 else "/tmp/s19/ka_maps.pkl"
d = pickle.load(open(pk, "rb"))
A, R = d["acmm"], d["regions"]
n = len(A["geometric 2"])
def rs(g, shape):
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * g.shape[0] / shape[0]), 0, g.shape[0] - 1).astype(int)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * g.shape[1] / shape[1]), 0, g.shape[1] - 1).astype(int)
    return g[np.ix_(rows, cols)]
gts, weaks = [], []
views = sorted(p for p in (room / "gt").glob("*.pfm"))
for i in range(n):
    shp = A["geometric 2"][i]["depth"].shape
    gts.append(rs(mvscope.read_pfm(views[i]), shp))
    w = room / "gt" / (views[i].stem + "_lowtex.png")
    weaks.append(rs(np.asarray(Image.open(w)) > 0, shp) if w.exists() else np.zeros(shp, bool))
def ok(dep, g, t):
    return (dep > 0) & (np.abs(dep - g) <= t * g)
for t in (0.02, 0.05):
    print(f"--- within {t*100:.0f}%")
    tot = {}
    for i in range(n):
        g = gts[i]; v = g > 0
        pr = R["planar prior"][i]["prior_depth"]
        hasp = (pr > 0) & v
        pok = ok(pr, g, t) & hasp
        classes = {"prior right": pok, "prior wrong": hasp & ~pok, "no prior": v & ~hasp}
        a = ok(A["geometric 2"][i]["depth"], g, t); r = ok(R["geometric 2"][i]["depth"], g, t)
        rb = ok(R["detail restorer"][i]["depth"], g, t); rp = ok(R["planar prior"][i]["depth"], g, t)
        ab = ok(A["detail restorer"][i]["depth"], g, t)
        for wk in (False, True):
            for k, m in classes.items():
                m = m & (weaks[i] if wk else v)
                key = ("weak " if wk else "all ") + k
                s = tot.setdefault(key, np.zeros(6))
                s += [m.sum(), (a & m).sum(), (r & m).sum(), (ab & m).sum(), (rb & m).sum(), (rp & m).sum()]
    allv = sum(int((g > 0).sum()) for g in gts)
    allw = sum(int((w & (g > 0)).sum()) for w, g in zip(weaks, gts))
    print(f"{'class':<20}{'share':>7}{'ACMMend':>9}{'REGend':>8}{'diff pts':>9}{'ACMMdr':>8}{'REGdr':>7}{'REGprior':>9}")
    for k, s in tot.items():
        den = allw if k.startswith("weak") else allv
        print(f"{k:<20}{100*s[0]/den:7.1f}{100*s[1]/max(s[0],1):9.1f}{100*s[2]/max(s[0],1):8.1f}{100*(s[2]-s[1])/den:9.2f}{100*s[3]/max(s[0],1):8.1f}{100*s[4]/max(s[0],1):7.1f}{100*s[5]/max(s[0],1):9.1f}")
