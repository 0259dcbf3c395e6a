import numpy as np, mvscope, pathlib, sys
from PIL import Image
out = pathlib.Path("/tmp/s25/bimodal/scene")
def dist_to_off(low):
    # brute-force distance (chebyshev approx via iterative dilation) to nearest non-low pixel
    H, W = low.shape
    d = np.full((H, W), 999, int); cur = ~low; d[cur] = 0; k = 0
    while (d == 999).any() and k < 60:
        k += 1
        n = cur.copy()
        n[1:] |= cur[:-1]; n[:-1] |= cur[1:]; n[:, 1:] |= cur[:, :-1]; n[:, :-1] |= cur[:, 1:]
        d[n & (d == 999)] = k; cur = n
    return d
bands = [(0, 4), (4, 8), (8, 12), (12, 20), (20, 999)]
tot = {m: np.zeros((len(bands), 2)) for m in sys.argv[1:]}
for v in range(5):
    g = mvscope.read_pfm(out / "gt" / f"{v:08d}.pfm")
    low = np.array(Image.open(out / "gt" / f"{v:08d}_lowtex.png")) > 0
    dd = dist_to_off(low)
    for m in sys.argv[1:]:
        e = mvscope.read_pfm(pathlib.Path(m) / "depth" / f"{v:08d}.pfm")
        ok = np.abs(e / g - 1) <= 0.02
        row = []
        for i, (lo, hi) in enumerate(bands):
            sel = low & (dd >= lo) & (dd < hi)
            tot[m][i] += [ (ok & sel).sum(), sel.sum() ]
            row.append(f"{100*(ok&sel).sum()/max(sel.sum(),1):5.1f}({sel.sum()})")
        print(f"v{v} {m:>14}: " + " ".join(row))
for m in sys.argv[1:]:
    print(f"all {m:>14}: " + " ".join(f"{lo}-{hi}: {100*a/b:5.1f}% of {int(b)}" for (lo,hi),(a,b) in zip(bands, tot[m])))
