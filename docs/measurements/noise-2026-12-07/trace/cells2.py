import sys, pathlib, warnings, time, json, numpy as np
import mvscope
room = pathlib.Path(sys.argv[1]); vi = int(sys.argv[2]); x0,x1,y0,y1 = map(int, sys.argv[3].split(',')); rest = sys.argv[4:]
# An optional LEVEL (0: coarsest) before the NAME=VALUE changes; the finest by default.
LEVEL = int(rest.pop(0)) if rest and rest[0].lstrip('-').isdigit() else None; sets = rest
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0, params={k: v for k, v in (a.split("=") for a in sets)})
last = s.num_levels - 1 if LEVEL is None else LEVEL
sp = [st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior") and st["view"] == vi and st["label"].endswith("support points")]
s.goto(sp[0] + 1)
v = scene.views[vi]
gt0 = mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm")
m = s.maps(vi); H0, W0 = gt0.shape; hh, ww = m.height, m.width
gt = gt0[np.ix_(np.clip(np.floor((np.arange(hh) + 0.5) * H0 / hh), 0, H0 - 1).astype(int), np.clip(np.floor((np.arange(ww) + 0.5) * W0 / ww), 0, W0 - 1).astype(int))]
print("level size", ww, hh, flush=True)
def err(p):
    px, py = p["pixel"]; t = gt[py, px]; return (p["depth"] - t) / t
out = []
t0 = time.time()
for y in range(y0, y1, 5):
    for x in range(x0, x1, 5):
        c = s.support_cell(vi, x, y)
        cand = c["candidates"]
        for p in cand: p["err"] = float(err(p))
        out.append({"x": x, "y": y, "chosen": c["chosen"], "by_flat": c["by_flat_window"], "candidates": cand})
        if len(out) == 2: print("two cells", round(time.time() - t0, 1), "s", flush=True)
import pickle; pickle.dump(out, open(f"/tmp/s47/ana/cells2{'' if LEVEL is None else f'L{LEVEL}'}-{vi}-{'on' if sets else 'off'}.pkl", "wb"))
ch = [next((p for p in o["candidates"] if o["chosen"] is not None and tuple(p["pixel"]) == tuple(o["chosen"])), None) for o in out]
e = np.array([abs(p["err"]) if p else np.nan for p in ch])
nflat = np.array([sum(p["flat"] for p in o["candidates"]) for o in out])
print(f"cells {len(out)}; chosen within 1% {np.nanmean(e<0.01):.2f}, 2% {np.nanmean(e<0.02):.2f}; by flat {np.mean([o['by_flat'] for o in out]):.2f}; flat candidates per cell {nflat.mean():.1f}")
print("eligibility of chosen:", {k: sum(1 for p in ch if p and p['eligibility']==k) for k in set(p['eligibility'] for p in ch if p)})
