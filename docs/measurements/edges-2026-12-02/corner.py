"""Dolls view 1's bottom-right corner (x 240-320, y 200-280 at 320): which region and plane
its cells take at the end of the finest scale's prior stage, under four settings."""
import sys, pathlib, warnings
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene_dir = pathlib.Path(sys.argv[1]); v = int(sys.argv[2]); x0, x1, y0, y1 = map(int, sys.argv[3].split(","))
scene = mvscope.Scene.open(scene_dir, max_image_size=320)
def resized(path, shape):
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    rows = np.clip(np.round((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0] - 0.5), 0, a.shape[0] - 1)
    cols = np.clip(np.round((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1] - 0.5), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
for sets in [{}, {"prior_flat_weighted": True}, {"prior_region_edge": True}, {"prior_flat_weighted": True, "prior_region_edge": True}]:
    s = mvscope.Session(scene, method="regions", seed=0, params=sets)
    last = s.num_levels - 1
    s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
    mesh, m = s.prior_mesh(v), s.maps(v)
    r = mesh["regions"]; c = r["cell"]
    gt = resized(scene_dir / "gt" / f"{v:08d}.pfm", (m.height, m.width))
    weak = resized(scene_dir / "gt" / f"{v:08d}_lowtex.png", (m.height, m.width)) & (gt > 0)
    win = np.zeros_like(weak); win[y0:y1, x0:x1] = True
    sel = weak & win
    yy, xx = np.nonzero(sel)
    reg = r["region"][yy // c, xx // c]; pl = r["plane"][yy // c, xx // c]
    pd = m["prior_depth"][sel]; g = gt[sel]
    right = (pd > 0) & (np.abs(pd - g) <= 0.02 * g)
    print(f"{sets}: {sel.sum()} weak px in the window; prior right {100*right.mean():.1f}%, none {100*np.mean(pd <= 0):.1f}%")
    for rid in np.unique(reg):
        mm = reg == rid
        size = r["sizes"][rid - 1] if rid > 0 else 0
        cells = int(np.sum(r["region"] == rid)) if rid > 0 else 0
        planes = [len(p["inliers"]) for p in r["planes"] if p["region"] + 1 == rid]
        ps = np.unique(pl[mm])
        print(f"   region {rid} ({cells} cells, {size} points, planes {planes}): {mm.sum()} px, their planes {ps.tolist()}, prior right {100*right[mm].mean():.1f}%, median prior/gt {np.median(np.where(pd[mm] > 0, pd[mm] / g[mm], np.nan)):.3f}")
    if "shades" in r and r["shades"] is not None:
        sh = r["shades"][y0 // c:y1 // c, x0 // c:x1 // c]
        print("   shades in the window (every 2nd cell):"); print(np.round(sh[::2, ::2]).astype(int))
