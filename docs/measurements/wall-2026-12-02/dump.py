"""kitchen-a (colour focal length), 320, seed 0, Regions at the end of the finest prior
stage: every view's support points, regions, final-stage depth inputs and truth, saved to
one .npz so the wall's points can be studied without rerunning (fit.py reads it)."""
import sys
import pathlib
import numpy as np
sys.path.insert(0, str(pathlib.Path(__file__).parent.parent / "table-2026-12-02"))
from truth import at_finest_prior, truth

d = sys.argv[1] if len(sys.argv) > 1 else "/tmp/s30/kroot/rgbd/kitchen-a"
out = sys.argv[2] if len(sys.argv) > 2 else "/tmp/wall-dump.npz"


def extrinsic(root, v):
    rows = open(f"{root}/cams/{v:08d}_cam.txt").read().split("\n")[1:5]
    return np.array([[float(x) for x in r.split()] for r in rows])


scene, s = at_finest_prior(d)
arrays = {}
for v in range(len(scene.views)):
    mesh, m = s.prior_mesh(v), s.maps(v)
    gt, weak = truth(d, f"{v:08d}", (m.height, m.width))
    r = mesh["regions"]
    k = np.array(scene.views[v].K) * (m.width / scene.views[v].width)
    arrays.update({f"{v}_points": mesh["points"], f"{v}_point_depth": mesh["point_depth"],
                   f"{v}_point_cost": mesh["point_cost"], f"{v}_region": r["region"],
                   f"{v}_sizes": np.array(r["sizes"]), f"{v}_cell": np.array(r["cell"]),
                   f"{v}_gt": gt, f"{v}_weak": weak, f"{v}_K": k, f"{v}_depth": m["depth"],
                   f"{v}_cost": m["cost"], f"{v}_prior_depth": m["prior_depth"],
                   f"{v}_normal": m["normal"], f"{v}_selected_count": m["selected_count"],
                   f"{v}_point_normal": mesh["point_normal"], f"{v}_E": extrinsic(d, v)})
np.savez_compressed(out, views=len(scene.views), **arrays)
print("saved", out)
