"""Kitchen-a (K526) at 320: why weak pixels get no prior in Regions (prior_mesh breakdown)."""
import pathlib, sys, warnings, pickle
import numpy as np
import mvscope
from PIL import Image
from common import KITCHEN_A, at_prior_end, open_scene, rs
room = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else KITCHEN_A)
method = sys.argv[2] if len(sys.argv) > 2 else "regions"
sets = dict(a.split("=") for a in sys.argv[3:])
scene = open_scene(room)
def truth(view, shape, suffix=".pfm"):
    p = room / "gt" / f"{view.scene_index:08d}{suffix}"
    if not p.exists(): return np.zeros(shape, bool)
    return rs(mvscope.read_pfm(p) if suffix == ".pfm" else np.asarray(Image.open(p)) > 0, shape)
params = {k: (v == "true" if v in ("true", "false") else float(v) if "." in v else int(v)) for k, v in sets.items()}
s = at_prior_end(scene, method, params)
T = {}
pts_ok = []
def add(k, m, w):
    a = T.setdefault(k, np.zeros(2)); a += [m.sum(), (m & w).sum()]
for v in scene.views:
    m = s.maps(v.index); mesh = s.prior_mesh(v.index)
    H, W = m.height, m.width
    g = truth(v, (H, W)); wk = truth(v, (H, W), "_lowtex.png") & (g > 0); val = g > 0
    pr = m["prior_depth"]
    right = (pr > 0) & (np.abs(pr - g) <= 0.02 * g) & val
    wrong = (pr > 0) & val & ~right
    R = mesh["regions"]; c = R["cell"]
    yy, xx = np.mgrid[0:H, 0:W]
    reg = R["region"][yy // c, xx // c]; pl = R["plane"][yy // c, xx // c]
    # per region: has any plane?
    nreg = len(R["sizes"])
    has_plane = np.zeros(nreg + 1, bool)
    for p in R["planes"]: has_plane[p["region"] + 1] = True
    sizes = np.array([0] + R["sizes"])
    # support points' correctness
    P = mesh["points"]; pd = mesh["point_depth"]
    gp = g[P[:, 1], P[:, 0]]
    pok = (gp > 0) & (np.abs(pd - gp) <= 0.02 * gp)
    cellp = (P[:, 1] // c) * R["region"].shape[1] + P[:, 0] // c
    preg = R["region"].ravel()[cellp]
    ok_in_reg = np.bincount(preg, weights=pok & (gp > 0), minlength=nreg + 1)
    val_in_reg = np.bincount(preg, weights=(gp > 0), minlength=nreg + 1)
    pts_ok.append((pok[gp > 0].mean(), pok[(gp > 0) & (preg > 0)].mean()))
    nop = val & (pr <= 0)
    cls = {
        "prior right": right, "prior wrong": wrong,
        "none: flat, region without points(<6)": nop & (reg > 0) & (sizes[reg] < 6),
        "none: flat, region no plane": nop & (reg > 0) & (sizes[reg] >= 6) & ~has_plane[reg],
        "none: flat, region has plane, cell not": nop & (reg > 0) & has_plane[reg] & (pl < 0),
        "none: flat, cell has plane(?)": nop & (reg > 0) & (pl >= 0),
        "none: not flat, outside hull (0)": nop & (reg == 0) & (pr == 0),
        "none: not flat, dropped triangle (-1)": nop & (reg == 0) & (pr == -1),
        "none: not flat, other code": nop & (reg == 0) & (pr != 0) & (pr != -1),
    }
    for k, mm in cls.items():
        add("all  " + k, mm, val); add("weak " + k, mm & wk, wk)
    # region-no-plane pixels: share of their region's points right
    rn = nop & (reg > 0) & (sizes[reg] >= 6) & ~has_plane[reg] & wk
    if rn.any():
        fr = ok_in_reg / np.maximum(val_in_reg, 1)
        T.setdefault("frac_ok_noplane", []).extend(fr[reg[rn]].tolist())
    q = nop & (reg > 0) & (pl >= 0) & wk
    if q.any():
        vals, cnt = np.unique(np.round(pr[q], 2), return_counts=True)
        T.setdefault("codes", {}); [T["codes"].__setitem__(a, T["codes"].get(a, 0) + b) for a, b in zip(vals.tolist(), cnt.tolist())]
        # depth the plane would give, vs the view's range
        P4 = R["planes"]; 
    tp = mesh["triangle_state"]
    T.setdefault("tri", np.zeros(3)); T["tri"] += np.bincount(tp, minlength=3)
allv = T["all  prior right"][0] + sum(T[k][0] for k in T if k.startswith("all  ") and k != "all  prior right")
allw = sum(T[k][0] for k in T if k.startswith("weak "))
for k, a in T.items():
    if k == "codes": print("codes of flat cells with a plane but no prior:", a); continue
    if isinstance(a, np.ndarray) and k != "tri":
        den = allw if k.startswith("weak") else allv
        print(f"{k:<45}{100*a[0]/den:7.1f}%")
print("triangles kept/degenerate/inconsistent", T["tri"])
print("support points right within 2%% (all, in flat regions): %.3f %.3f" % tuple(np.mean(pts_ok, axis=0)))
if "frac_ok_noplane" in T:
    f = np.array(T["frac_ok_noplane"]); print("weak no-plane pixels: their region's points right, p25/50/75", np.percentile(f, [25, 50, 75]))
