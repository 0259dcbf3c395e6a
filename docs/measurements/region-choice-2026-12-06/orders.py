"""The same view's reprojection error under Regions' two orders: its own (the prior from the
restorer's result) and `prior_after_geometric`. Per view, the median of the last geometric
pass's forward-backward reprojection error over the pixels a source sends back within delta,
and the depth maps' share within 2% of the truth, for each order."""
import sys
import numpy as np
import mvscope

for path in sys.argv[1:]:
    scene = mvscope.Scene.open(path, max_image_size=320)
    rows = {}
    for name, params in [("own", {}), ("after", {"prior_after_geometric": True})]:
        s = mvscope.Session(scene, method="regions", seed=0, params=params)
        s.run()
        delta = s.params["delta"]
        out = []
        for v in range(len(scene)):
            m = s.maps(v)
            d = m["depth"]
            e = m["reprojection_error"][d > 0]
            inside = e[e < delta]
            g = mvscope.read_pfm(f"{path}/gt/{v:08}.pfm")
            h, w = d.shape
            t = g[np.arange(h) * g.shape[0] // h][:, np.arange(w) * g.shape[1] // w]
            ok = t > 0
            right = float(np.mean(np.abs(d[ok] - t[ok]) <= 0.02 * t[ok]))
            out.append((float(np.median(inside)) if inside.size else float("nan"), right))
        rows[name] = out
    print(path)
    for v in range(len(scene)):
        (eo, ro), (ea, ra) = rows["own"][v], rows["after"][v]
        print(f"  view {v}: error own {eo:.2f} after {ea:.2f} px | within 2% own {ro:.3f} "
              f"after {ra:.3f}", flush=True)
