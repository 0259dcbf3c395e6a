"""kitchen-a (colour focal length), 320, seed 0, Regions' defaults: the weak pixels in flat
regions without a plane at the end of the finest prior stage, by their region's number of
support points and whether RANSAC kept any plane in it. PARAMS (JSON) sets parameters."""
import sys, os, json
import numpy as np
from truth import at_finest_prior, truth
d = sys.argv[1] if len(sys.argv) > 1 else "/tmp/s30/kroot/rgbd/kitchen-a"
scene, s = at_finest_prior(d, json.loads(os.environ.get("PARAMS", "{}")))
bins = [0, 8, 16, 32, 64, 128, 10**9]
tot_weak = 0
hist = np.zeros((2, len(bins) - 1))
for v in range(len(scene.views)):
    mesh, m = s.prior_mesh(v), s.maps(v)
    gt, weak = truth(d, f"{v:08d}", (m.height, m.width))
    weak &= gt > 0
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
