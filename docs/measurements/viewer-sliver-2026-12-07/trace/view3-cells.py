# The shipped ICL's view 3 (Regions' defaults, 320): the cells under the pixels that move with
# the seed (view3.py) — flat or not, in which region, held by a plane or not — at seeds 0 and 1.
import warnings, numpy as np, mvscope
I = '/work/shared/data/rgbd/icl-livingroom'
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(I, max_image_size=320)
def res(a, shape):
    r = (np.floor((np.arange(shape[0]) + .5) * a.shape[0] / shape[0])).astype(int)
    c = (np.floor((np.arange(shape[1]) + .5) * a.shape[1] / shape[1])).astype(int)
    return a[np.ix_(r, c)]
out = {}
for seed in (0, 1):
    s = mvscope.Session(scene, method="regions", seed=seed)
    last = s.num_levels - 1
    s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
    m, mesh = s.maps(3), s.prior_mesh(3)
    r = mesh["regions"]
    if seed == 0:
        print("region fields:", sorted(r.keys()))
    rows, cols = np.arange(m.height)[:, None] // r["cell"], np.arange(m.width) // r["cell"]
    out[seed] = dict(region=np.asarray(r["region"])[rows, cols].copy(), assigned=(np.asarray(r["plane"])[rows, cols] + 1).copy(),
                     cell=r["cell"], nreg=int(np.asarray(r["region"]).max()), npts=len(mesh["points"]) if "points" in mesh else -1)
    s.run()
    out[seed]["final"] = s.maps(3)["depth"].copy()
g = res(mvscope.read_pfm(f'{I}/gt/00000003.pfm'), out[0]["final"].shape)
ok = g > 0
w = {k: (np.abs(out[k]["final"] / np.where(ok, g, 1) - 1) <= 0.02) & ok for k in out}
lost = w[0] & ~w[1]
print("lost", int(lost.sum()))
for k in (0, 1):
    reg, asg = out[k]["region"], out[k]["assigned"]
    print(f"seed {k}: cell {out[k]['cell']} px, regions {out[k]['nreg']}, support points {out[k]['npts']}; "
          f"view's pixels in a flat region {float((reg > 0).mean()):.3f}, held by a plane {float((asg > 0).mean()):.3f}")
    print(f"   lost pixels: in a flat region {float((reg[lost] > 0).mean()):.3f}, held {float((asg[lost] > 0).mean()):.3f}")
    ids, n = np.unique(reg[lost], return_counts=True)
    top = sorted(zip(n.tolist(), ids.tolist()), reverse=True)[:5]
    print("   regions under lost pixels (count, region):", top, " region sizes (px):", {int(i): int((reg == i).sum()) for _, i in top})
