import pickle, numpy as np
off = pickle.load(open("/tmp/s47/ana/cells2L1-2-off.pkl", "rb")); on = pickle.load(open("/tmp/s47/ana/cells2L1-2-on.pkl", "rb"))
def chosen(o):
    return next((p for p in o["candidates"] if o["chosen"] is not None and tuple(p["pixel"]) == tuple(o["chosen"])), None)
moved = 0; flatdiff = 0; depthdiff = 0
for a, b in zip(off, on):
    ca, cb = chosen(a), chosen(b)
    fa = sum(p["flat"] for p in a["candidates"]); fb = sum(p["flat"] for p in b["candidates"])
    da = np.array([p["depth"] for p in a["candidates"]]); db = np.array([p["depth"] for p in b["candidates"]])
    same_depths = np.allclose(da, db)
    depthdiff += not same_depths; flatdiff += fa != fb
    sa = (tuple(ca["pixel"]), round(ca["err"], 4), ca["eligibility"]) if ca else None
    sb = (tuple(cb["pixel"]), round(cb["err"], 4), cb["eligibility"]) if cb else None
    if sa != sb:
        moved += 1
    print(f"cell ({a['x']},{a['y']}): flat {fa}/{len(a['candidates'])} -> {fb}; depths same {same_depths}; chosen off {sa} on {sb}")
print(f"cells {len(off)}: chosen point differs in {moved}; flat count differs in {flatdiff}; candidate depths differ in {depthdiff}")
for tag, out in (("off", off), ("on", on)):
    e = np.array([abs(chosen(o)["err"]) if chosen(o) else np.nan for o in out])
    print(tag, f"chosen within 1% {np.nanmean(e < 0.01):.2f}, 2% {np.nanmean(e < 0.02):.2f}, n {np.sum(~np.isnan(e))}")
