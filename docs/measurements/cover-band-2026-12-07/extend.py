# Each finest-scale region plane of a view extended over the pixels another plane paints:
# the share of those pixels it would put within 2% of the truth. Usage: extend.py SCENE VIEW [NAME=VALUE...]
import sys, pathlib, warnings, numpy as np
import mvscope
room = pathlib.Path(sys.argv[1]); vi = int(sys.argv[2]); sets = sys.argv[3:]
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0, params={k: v for k, v in (a.split("=") for a in sets)})
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
v = scene.views[vi]; m, mesh = s.maps(vi), s.prior_mesh(vi)
t = (room / "cams" / f"{v.scene_index:08d}_cam.txt").read_text().split()
K = np.array(t[18:27], float).reshape(3, 3)
gtf = mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm"); sc = m.width / gtf.shape[1]; K[:2] *= sc
gt = gtf[np.ix_(np.clip(np.floor((np.arange(m.height) + 0.5) / sc), 0, gtf.shape[0] - 1).astype(int), np.clip(np.floor((np.arange(m.width) + 0.5) / sc), 0, gtf.shape[1] - 1).astype(int))]
r = mesh["regions"]; c = r["cell"]
plane_px = r["plane"][np.arange(m.height)[:, None] // c, np.arange(m.width) // c]
ys, xs = np.mgrid[0:m.height, 0:m.width]
rays = np.stack([xs, ys, np.ones_like(xs)], -1) @ np.linalg.inv(K).T
big = [k for k in range(len(r["planes"])) if (plane_px == k).sum() >= 500]
print("settings:", " ".join(sets) or "defaults", f"| view {vi}: rows paint, columns the plane extended over them (share within 2%)")
print("painted by".ljust(22) + "".join(f"plane {k:2d} " for k in big))
for a in big:
    px = (plane_px == a) & (gt > 0)
    row = []
    for b in big:
        n = np.asarray(r["planes"][b]["plane"], float)
        d = -n[3] / (rays[px] @ n[:3])
        row.append(np.mean(np.abs(d - gt[px]) <= 0.02 * gt[px]))
    print(f"plane {a:2d} ({int(px.sum()):5d} px)".ljust(22) + "".join(f"{x:8.2f} " for x in row))
