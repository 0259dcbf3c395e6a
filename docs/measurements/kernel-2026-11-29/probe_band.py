import numpy as np, mvscope, pathlib, sys, warnings
from PIL import Image
warnings.simplefilter("ignore")
out = pathlib.Path("/tmp/s25/bimodal/scene")
sys.path.insert(0, "/tmp/s27")
def near_off(low, g):
    H, W = low.shape
    d = np.full((H, W), 999, int); nd = np.zeros((H, W)); cur = ~low; d[cur] = 0; nd[cur] = g[cur]; k = 0
    while (d == 999).any() and k < 60:
        k += 1
        n = cur.copy(); ndn = nd.copy()
        for sl_to, sl_from in [((slice(1,None),), (slice(None,-1),)), ((slice(None,-1),), (slice(1,None),)),
                               ((slice(None), slice(1,None)), (slice(None), slice(None,-1))), ((slice(None), slice(None,-1)), (slice(None), slice(1,None)))]:
            add = cur[sl_from] & ~n[sl_to]
            n[sl_to] |= cur[sl_from]
            t = ndn[sl_to]; t[add] = nd[sl_from][add]
        new = n & (d == 999); d[new] = k; nd[new] = ndn[new]; cur = n
    return d, nd
scene = mvscope.Scene.open(out)
method = sys.argv[1] if len(sys.argv) > 1 else "regions"
s = mvscope.Session(scene, method=method, seed=0)
s.goto(len(s.steps))
np.save(f"/tmp/s27/{method}_depths.npy", np.array([s.maps(v)["depth"] for v in range(5)]))
for v in range(5):
    m = s.maps(v)
    g = mvscope.read_pfm(out / "gt" / f"{v:08d}.pfm")
    low = np.array(Image.open(out / "gt" / f"{v:08d}_lowtex.png")) > 0
    dd, nd = near_off(low, g)
    e = m["depth"]; r = e / g; ok = np.abs(r - 1) <= 0.02
    occ = nd < 0.95 * g      # the nearest other surface is in front: an occluding edge
    band = low & (dd < 8)
    pd = m["prior_depth"] if method != "acmm" else np.zeros_like(e)
    for name, sel in [("occl", band & occ), ("crease", band & ~occ)]:
        n = sel.sum()
        if n == 0: continue
        atfg = np.abs(e / nd - 1) <= 0.03
        hasp = pd > 0; pok = np.abs(pd / g - 1) <= 0.02
        w = m["winner"][sel]
        print(f"v{v} {name:6s} {n:5d}: right {100*ok[sel].mean():5.1f}%  at near surface's depth {100*atfg[sel].mean():5.1f}%  "
              f"prior {100*hasp[sel].mean():5.1f}% (right {100*(pok&sel).sum()/max((hasp&sel).sum(),1):5.1f}%)  cost med {np.median(m['cost'][sel]):.3f}  winners {np.bincount(w, minlength=16).tolist()}")
