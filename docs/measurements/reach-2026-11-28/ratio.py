import pathlib, pickle, numpy as np, mvscope
from PIL import Image
from common import KITCHEN_A, at_prior_end, open_scene, rs
room = KITCHEN_A
d = pickle.load(open("/tmp/s19/ka_maps_ramp.pkl", "rb"))
views = sorted((room / "gt").glob("*[0-9].pfm"))
for i in (0, 3, 5):
    m = d["acmm"]["geometric 2"][i]; g = rs(mvscope.read_pfm(views[i]), m["depth"].shape)
    H, W = g.shape
    box = (slice(int(H*0.30), int(H*0.45)), slice(int(W*0.02), int(W*0.62)))
    r = m["depth"][box] / g[box]; r = r[np.isfinite(r) & (g[box] > 0)]
    print(i, "cabinet box depth/truth p10/25/50/75/90", np.round(np.percentile(r, [10, 25, 50, 75, 90]), 3), "truth median", np.median(g[box]))
    r2 = m["depth"] / g; r2 = r2[(g > 0)]
    print("   whole view ratio p25/50/75", np.round(np.percentile(r2, [25, 50, 75]), 3))
