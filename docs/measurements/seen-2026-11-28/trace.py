"""Weak pixels by their prior under two configurations of Regions (A: defaults, B: --set ...), and
how each transition class ends within 2% under A and B."""
import pathlib, sys
import numpy as np, mvscope
from PIL import Image
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "reach-2026-11-28"))  # common.py
from common import at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1])
pb = dict(kv.split("=") for kv in sys.argv[2:])
pb = {k: (v == "true" if v in ("true", "false") else float(v) if "." in v else int(v)) for k, v in pb.items()}
scene = open_scene(room)
def classes(s):
    out = []
    for v in scene.views:
        m, mesh = s.maps(v.index), s.prior_mesh(v.index); H, W = m.height, m.width
        g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
        r = mesh["regions"]; c = r["cell"]
        plane = r["plane"][np.arange(H)[:, None] // c, np.arange(W) // c]
        # first plane of its region or a further one
        first = {}
        for k, p in enumerate(r["planes"]):
            first.setdefault(p["region"], k)
        isfirst = np.vectorize(lambda k: k >= 0 and first.get(r["planes"][k]["region"]) == k)(plane) if len(r["planes"]) else np.zeros((H, W), bool)
        pr = m["prior_depth"]
        right = (pr > 0) & (np.abs(pr - g) <= 0.02 * g)
        cl = np.full((H, W), "none", dtype=object)
        cl[(pr > 0) & (plane < 0)] = "tri"
        cl[(pr > 0) & (plane >= 0) & isfirst] = "p1"
        cl[(pr > 0) & (plane >= 0) & ~isfirst] = "pN"
        rw = np.where(right, "+", np.where(pr > 0, "-", ""))
        out.append(np.char.add(cl.astype(str), rw.astype(str)))
    return out
A = at_prior_end(scene); B = at_prior_end(scene, params=pb)
ca, cb = classes(A), classes(B)
A.run(); B.run()
tot = {}
for v, xa, xb in zip(scene.views, ca, cb):
    H, W = xa.shape
    g = rs(mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"), (H, W))
    w = room / "gt" / f"{v.scene_index:08d}_lowtex.png"
    wk = (rs(np.asarray(Image.open(w)) > 0, (H, W)) if w.exists() else np.zeros((H, W), bool)) & (g > 0)
    oka = np.abs(A.depth(v.index) - g) <= 0.02 * g; okb = np.abs(B.depth(v.index) - g) <= 0.02 * g
    key = np.char.add(np.char.add(xa, " -> "), xb)
    for k in np.unique(key[wk]):
        mk = wk & (key == k)
        t = tot.setdefault(k, np.zeros(3)); t += [mk.sum(), (mk & oka).sum(), (mk & okb).sum()]
allw = sum(t[0] for t in tot.values())
print(f"{'A -> B prior':<16}{'share':>7}{'A end':>7}{'B end':>7}{'B-A pts':>9}")
for k, t in sorted(tot.items(), key=lambda kv: -kv[1][0]):
    print(f"{k:<16}{100*t[0]/allw:7.1f}{100*t[1]/max(t[0],1):7.1f}{100*t[2]/max(t[0],1):7.1f}{100*(t[2]-t[1])/allw:9.2f}")
print(f"weak within 2%: A {100*sum(t[1] for t in tot.values())/allw:.1f}  B {100*sum(t[2] for t in tot.values())/allw:.1f}")
