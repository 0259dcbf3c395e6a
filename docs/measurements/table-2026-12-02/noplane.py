"""kitchen-a (colour focal length), 320, seed 0, Regions' defaults: the weak pixels in flat
regions without a plane at the end of the finest prior stage, by their region's number of
support points and whether RANSAC kept any plane in it. PARAMS (JSON) sets parameters."""
import sys, pathlib, warnings
import numpy as np
import matplotlib; matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope
warnings.simplefilter("ignore", mvscope.SceneWarning)
d = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/s30/kroot/rgbd/kitchen-a")
scene = mvscope.Scene.open(d, max_image_size=320)
def resized(a, shape):
    if a.ndim == 3: a = a[..., 0]
    rows = np.clip(np.round((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0] - 0.5), 0, a.shape[0] - 1)
    cols = np.clip(np.round((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1] - 0.5), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
import os, json
s = mvscope.Session(scene, method="regions", seed=0, params=json.loads(os.environ.get("PARAMS", "{}")))
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
bins = [0, 8, 16, 32, 64, 128, 10**9]
tot_weak = 0
hist = np.zeros((2, len(bins) - 1))
for v in range(len(scene.views)):
    mesh, m = s.prior_mesh(v), s.maps(v)
    gt = resized(np.asarray(mvscope.read_pfm(d / "gt" / f"{v:08d}.pfm")), (m.height, m.width))
    weak = resized(plt.imread(d / "gt" / f"{v:08d}_lowtex.png") > 0, (m.height, m.width)) & (gt > 0)
    r = mesh["regions"]; c = r["cell"]
    ys, xs = np.arange(m.height)[:, None] // c, np.arange(m.width)[None, :] // c
    reg = r["region"][ys, xs]; pl = r["plane"][ys, xs]
    sizes = np.array(r["sizes"])
    with_plane = {q["region"] + 1 for q in r["planes"]}
    nop = weak & (reg > 0) & (pl < 0)
    tot_weak += weak.sum()
    for lab in np.unique(reg[nop]):
        n = sizes[lab - 1] if lab - 1 < len(sizes) else 0
        k = np.searchsorted(bins, n, side="right") - 1
        hist[int(lab in with_plane), k] += np.sum(nop & (reg == lab))
    print(f"view {v}: weak {weak.sum()}, in flat regions without a plane {100*nop.sum()/weak.sum():.1f}%, "
          f"regions {int(np.sum(sizes > 0))} with points, planes kept {len(r['planes'])}", flush=True)
print("weak pixels in flat regions without a plane, by their region's support points (share of all weak pixels):")
for k in range(len(bins) - 1):
    print(f"  {bins[k]:>4}-{bins[k+1]-1 if bins[k+1] < 10**9 else 'more':>5} points: region has no plane {100*hist[0,k]/tot_weak:5.1f}%, "
          f"region keeps a plane elsewhere {100*hist[1,k]/tot_weak:5.1f}%")
