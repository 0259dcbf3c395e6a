"""A camera test a run could make before its end: after Regions' run (its own order), each
view's forward-backward reprojection error through its sources (the last geometric pass's
Measure step, truncated at delta): the median below delta, the share below delta and the
share under 1 px over the pixels with a depth, per view and over the scene. Compares scenes whose cameras are off (ICL and
kitchen-a as shipped) with the same scenes' corrected cameras."""
import sys
import numpy as np
import mvscope

for path in sys.argv[1:]:
    scene = mvscope.Scene.open(path, max_image_size=320)
    s = mvscope.Session(scene, method="regions", seed=0)
    s.run()
    delta = s.params["delta"]
    meds, under, seen = [], [], []
    for v in range(len(scene)):
        m = s.maps(v)
        e = m["reprojection_error"][m["depth"] > 0]
        # Below delta: a source sees the pixel and sends it back within delta.
        inside = e[e < delta]
        seen.append(float(inside.size / max(e.size, 1)))
        meds.append(float(np.median(inside)) if inside.size else float("nan"))
        under.append(float(np.mean(e < 1.0)))
    print(f"{path}: per view, median error below delta {', '.join(f'{x:.2f}' for x in meds)} px"
          f" (share below delta {', '.join(f'{x:.2f}' for x in seen)}); mean share under 1 px"
          f" {np.mean(under):.3f}", flush=True)
