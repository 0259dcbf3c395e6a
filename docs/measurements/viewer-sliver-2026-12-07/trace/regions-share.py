# The shipped ICL (Regions' defaults, 320, seed 0), after the finest planar prior: per view, the
# flat share, the largest region's share of the view, and the share a region plane holds.
import warnings, numpy as np, mvscope
I = '/work/shared/data/rgbd/icl-livingroom'
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(I, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0)
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
for v in scene.views:
    r = s.prior_mesh(v.index)["regions"]
    reg, pl = np.asarray(r["region"]), np.asarray(r["plane"])
    ids, n = np.unique(reg[reg > 0], return_counts=True)
    print(f"view {v.index}: cells {reg.size}, flat {float((reg > 0).mean()):.3f}, regions {len(ids)}, "
          f"largest {float(n.max() / reg.size) if len(n) else 0:.3f}, held by a plane {float((pl >= 0).mean()):.3f}, planes {len(r['planes'])}")
