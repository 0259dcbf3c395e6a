# Registered ICL, view 3, Regions (320, seed 0): the finest prior's plane 0 (the left wall's,
# painted over the whole corner region), where it is wrong, and what the final map has there.
import os, warnings, numpy as np, mvscope
I = os.environ.get('SCENE', '/tmp/scenes/extra/rgbd/icl-reg')
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(I, max_image_size=320)
gt = mvscope.read_pfm(f'{I}/gt/00000003.pfm')
s = mvscope.Session(scene, method="regions", seed=0)
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
mesh = s.prior_mesh(3); mp = s.maps(3)
pd_ = np.asarray(mp["prior_depth"]); before = np.asarray(mp["depth"]); H, W = pd_.shape
ys, xs = np.mgrid[0:H, 0:W]
g = gt[np.clip(((ys + 0.5) * gt.shape[0] / H).astype(int), 0, gt.shape[0]-1), np.clip(((xs + 0.5) * gt.shape[1] / W).astype(int), 0, gt.shape[1]-1)]
r = mesh["regions"]; cell = r["cell"]; plane_of = np.asarray(r["plane"])
pc = plane_of[np.clip(ys // cell, 0, plane_of.shape[0]-1), np.clip(xs // cell, 0, plane_of.shape[1]-1)]
s.run()
final = np.asarray(s.maps(3)["depth"])
ok = lambda d: np.abs(d / np.where(g > 0, g, np.nan) - 1) <= 0.02
valid = g > 0
print(f"view 3 at {W}x{H}: {len(r['planes'])} planes; prior covers {np.mean(pd_[valid] > 0):.3f} of the pixels")
for k, p in enumerate(r["planes"]):
    m = valid & (pc == k) & (pd_ > 0)
    if m.sum() < 200: continue
    right, wrong = m & ok(pd_), m & ~ok(pd_)
    far = m & (np.abs(pd_ / np.where(g > 0, g, np.nan) - 1) > 0.05)
    print(f"plane {k} (region {p['region']}, {len(p['inliers'])} inliers): paints {m.sum()} px; prior within 2% on {right.sum()}, >5% off on {far.sum()}; "
          f"final within 2%: where the prior was right {np.mean(ok(final)[right]):.2f}, where >5% off {np.mean(ok(final)[far]) if far.any() else float('nan'):.2f}; "
          f"the depth the prior was built from, within 2% where >5% off: {np.mean(ok(before)[far]) if far.any() else float('nan'):.2f}")
m = valid & (pd_ > 0)
print(f"all prior pixels: within 2% {np.mean(ok(pd_)[m]):.3f}; final within 2% over the view {np.mean(ok(final)[valid]):.3f}")
