import sys, warnings, pathlib
import numpy as np
import mvscope
warnings.simplefilter("ignore")
out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/s25/bimodal/scene")
method = sys.argv[2] if len(sys.argv) > 2 else "regions"
scene = mvscope.Scene.open(out)
s = mvscope.Session(scene, method=method, seed=0)
last = s.num_levels - 1
pri = max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior"))
s.goto(pri + 1)
d = {}
for v in scene.views:
    mesh = s.prior_mesh(v.index); r = mesh["regions"]
    d[f"pts{v.index}"] = mesh["points"]; d[f"pd{v.index}"] = mesh["point_depth"]
    d[f"reg{v.index}"] = r["region"]; d[f"cell"] = r["cell"]
    d[f"K{v.index}"] = v.K
    d[f"planes{v.index}"] = np.array([len(p["inliers"]) for p in r["planes"]])
    d[f"preg{v.index}"] = np.array([p["region"] for p in r["planes"]])
np.savez("/tmp/s26/points.npz", **d)
print("saved")
