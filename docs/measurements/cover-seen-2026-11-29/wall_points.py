import sys, warnings, pathlib
import numpy as np
import matplotlib; matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope
warnings.simplefilter("ignore")
out = pathlib.Path("/tmp/s25/bimodal/scene")
scene = mvscope.Scene.open(out)
seed = int(sys.argv[1])
s = mvscope.Session(scene, method="regions", seed=seed)
last = s.num_levels - 1
for lvl in [last]:
    pri = max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (lvl, "planar prior"))
    s.goto(pri + 1)
    for v in scene.views:
        mesh = s.prior_mesh(v.index)
        m = s.maps(v.index)
        g = mvscope.read_pfm(out / "gt" / f"{v.scene_index:08d}.pfm")
        H, W = g.shape
        r = mesh["regions"]
        pts = mesh["points"]; pd = mesh["point_depth"]; pc = mesh["point_cost"]
        # scale point coords to gt resolution
        sx, sy = W / m.width, H / m.height
        gx = np.clip((pts[:, 0] * sx).astype(int), 0, W - 1); gy = np.clip((pts[:, 1] * sy).astype(int), 0, H - 1)
        gt = g[gy, gx]
        ratio = pd / np.where(gt > 0, gt, np.nan)
        cell = r["cell"]
        reg = r["region"][pts[:, 1] // cell, pts[:, 0] // cell]
        ids, cnt = np.unique(reg[reg > 0], return_counts=True)
        big = ids[np.argmax(cnt)] if len(ids) else 0
        sel = reg == big
        rr = ratio[sel]
        ok = np.abs(rr - 1) <= 0.02
        planes = [len(p["inliers"]) for p in r["planes"] if p["region"] == big]
        hist = np.histogram(rr[np.isfinite(rr)], bins=[0, .5, .8, .9, .95, .98, 1.02, 1.05, 1.1, 1.25, 2, 10])[0]
        print(f"L{lvl} v{v.index} {m.width}x{m.height} region {big}: {sel.sum()} pts, right {ok.sum()} ({100*ok.mean():.0f}%), planes {planes}, cost right {np.median(pc[sel][ok]) if ok.any() else -1:.2f} wrong {np.median(pc[sel][~ok]) if (~ok).any() else -1:.2f}; ratio hist {hist.tolist()}")
        f=np.isfinite(rr)
        print("   within 0.5/1/2%:", [(np.abs(rr[f]-1)<=t).sum() for t in (0.005,0.01,0.02)], "median ratio of right", np.median(rr[ok]), "fine hist", np.histogram(rr[f],bins=np.linspace(0.97,1.03,13))[0].tolist())
        if lvl == last and v.index == 0:
            fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
            ax[0].imshow(v.image(), cmap="gray")
            c = ax[0].scatter(pts[sel, 0] * sx, pts[sel, 1] * sy, s=4, c=np.clip(rr, 0.8, 1.2), cmap="coolwarm"); plt.colorbar(c, ax=ax[0])
            ax[1].scatter(pts[sel, 0], rr, s=3); ax[1].set_ylim(0.7, 1.3); ax[1].set_xlabel("x"); ax[1].set_ylabel("depth/truth")
            fig.savefig("/tmp/s26/probe_v0.png", dpi=70)
