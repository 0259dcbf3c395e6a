# Does a region plane's own photometric cost tell a wrong plane from a right one? With the
# restart exact (prior_init_depth = prior_init_normal = 0), the cost right after the prior
# stage's init is the prior plane's own matching cost (top-K mean) where the pixel restarted;
# it is compared, per finest-scale region plane, with the cost of the depths the pixel had
# before the stage. Usage: plane_cost.py SCENE [NAME=VALUE...]
import sys, pathlib, warnings, numpy as np, matplotlib
matplotlib.use("Agg"); import matplotlib.pyplot as plt
import mvscope
room = pathlib.Path(sys.argv[1]); sets = sys.argv[2:] + ["prior_init_depth=0", "prior_init_normal=0"]
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0, params={k: v for k, v in (a.split("=") for a in sets)})
last = s.num_levels - 1
print("settings:", " ".join(sets))
for v in scene.views:
    steps = [st for st in s.steps if st["level"] == last and st["stage"] == "planar prior" and st["view"] == v.index]
    first = min(st["index"] for st in steps)
    init = [st["index"] for st in steps if st["label"].endswith("· init")][0]
    s.goto(first); before = s.maps(v.index)
    s.goto(init + 1); after = s.maps(v.index); mesh = s.prior_mesh(v.index)
    gtf = mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"); sc = after.width / gtf.shape[1]
    gt = gtf[np.ix_(np.clip(np.floor((np.arange(after.height) + 0.5) / sc), 0, gtf.shape[0] - 1).astype(int), np.clip(np.floor((np.arange(after.width) + 0.5) / sc), 0, gtf.shape[1] - 1).astype(int))]
    r = mesh["regions"]; c = r["cell"]
    plane_px = r["plane"][np.arange(after.height)[:, None] // c, np.arange(after.width) // c]
    prior = after["prior_depth"]
    right = (prior > 0) & (gt > 0) & (np.abs(prior - gt) <= 0.02 * gt)
    was_right = (before["depth"] > 0) & (gt > 0) & (np.abs(before["depth"] - gt) <= 0.02 * gt)
    restarted = (prior > 0) & (before["cost"] >= 0.1) & (gt > 0)
    print(f"view {v.index}:")
    for k in range(len(r["planes"])):
        px = (plane_px == k) & restarted
        if px.sum() < 100: continue
        cb, ca = before["cost"][px], after["cost"][px]
        print(f"   plane {k:2d}: restarted {int(px.sum()):5d}, prior right {right[px].mean():4.2f} (depths before {was_right[px].mean():4.2f}); "
              f"cost before {np.median(cb):.3f}, the plane's {np.median(ca):.3f}; the plane's lower on {np.mean(ca < cb):.2f}")
