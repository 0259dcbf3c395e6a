"""kitchen-a (focal 526.5), Regions at 320, seed 0: at the finest scale's support-point step
of each view, every cell's chosen support point against the truth, and what else the cell
offered (mvscope.Session.support_cell)."""
import sys, collections
import numpy as np
import mvscope

root = "/tmp/s16/k526/rgbd/kitchen-a"
scene = mvscope.Scene.open(root, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0)
steps = s.steps
stats = collections.Counter()
diffs = []
for view in [int(v) for v in sys.argv[1:]] or [0]:
    idx = max(i for i, st in enumerate(steps) if st["action"] == "support points" and st["view"] == view)
    s.goto(idx + 1)
    m = s.maps(view)
    h, w = m.height, m.width
    gt = mvscope.read_pfm(f"{root}/gt/{view:08d}.pfm")
    gh, gw = gt.shape[:2]
    ys = (np.arange(h) * gh // h); xs = (np.arange(w) * gw // w)
    t = gt[np.ix_(ys, xs)] if gt.ndim == 2 else gt[np.ix_(ys, xs)][..., 0]
    ok = lambda p, d: t[p[1], p[0]] > 0 and abs(d - t[p[1], p[0]]) / t[p[1], p[0]] < 0.02
    for y in range(0, h, 5):
        for x in range(0, w, 5):
            c = s.support_cell(view, x, y)
            if c is None or c["chosen"] is None:
                stats["no point"] += 1
                continue
            ch = next(k for k in c["candidates"] if tuple(k["pixel"]) == tuple(c["chosen"]))
            if t[ch["pixel"][1], ch["pixel"][0]] <= 0:
                stats["no truth"] += 1
                continue
            kind = "flat" if c["by_flat_window"] else "cost"
            if ok(ch["pixel"], ch["depth"]):
                stats[f"{kind}: right"] += 1
                continue
            stats[f"{kind}: wrong"] += 1
            elig = [k for k in c["candidates"] if k["eligibility"] in ("below cost limit", "flat window")]
            right_elig = [r for r, k in enumerate(elig) if ok(k["pixel"], k["depth"])]
            right_any = [k for k in c["candidates"] if ok(k["pixel"], k["depth"])]
            if right_elig:
                r = elig[min(right_elig)]
                diffs.append((r["cost"] - ch["cost"], (r["confidence"] or 0) - (ch["confidence"] or 0), r["score"] - ch["score"], abs(ch["depth"] - t[ch["pixel"][1], ch["pixel"][0]]) / t[ch["pixel"][1], ch["pixel"][0]], r["flat"], ch["flat"]))
                stats[f"{kind}: wrong, a right eligible pixel ranked {min(right_elig)+1 if min(right_elig) < 3 else '4+'}"] += 1
            elif right_any:
                stats[f"{kind}: wrong, right pixels only " + "/".join(sorted({k['eligibility'] for k in right_any}))] += 1
            else:
                stats[f"{kind}: wrong, no right pixel in the cell"] += 1
for k in sorted(stats):
    print(f"{stats[k]:6d}  {k}")

d = np.array([x[:4] for x in diffs])
print("cells where a right pixel could have been chosen:", len(d))
for name, col in [("cost (right - chosen)", 0), ("confidence (right - chosen)", 1), ("score (right - chosen)", 2), ("chosen's relative depth error", 3)]:
    q = np.percentile(d[:, col], [10, 25, 50, 75, 90])
    print(f"{name:32s} p10 {q[0]:+.3f} p25 {q[1]:+.3f} median {q[2]:+.3f} p75 {q[3]:+.3f} p90 {q[4]:+.3f}")
print("right one has more confidence in", int((d[:, 1] > 0).sum()), "cheaper in", int((d[:, 0] < 0).sum()))
print("flat (right, chosen):", collections.Counter((x[4], x[5]) for x in diffs))
