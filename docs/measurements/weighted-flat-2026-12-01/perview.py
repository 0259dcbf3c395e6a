import sys, pathlib
import numpy as np
exec(open(pathlib.Path(__file__).with_name("edge_error.py")).read().split("run, scene =")[0])
scene = pathlib.Path(sys.argv[1])
for run in sys.argv[2:]:
    run = pathlib.Path(run); out = []
    for dpath in sorted((run / "depth").glob("*.pfm")):
        d = read_pfm(dpath); h, w = d.shape
        gt = resample(read_pfm(scene / "gt" / dpath.name), h, w)
        weak = resample(plt.imread(scene / "gt" / dpath.name.replace(".pfm", "_lowtex.png")) > 0, h, w) & (gt > 0)
        ok = (d > 0) & (np.abs(d - gt) <= 0.02 * gt)
        out.append(f"{100*ok[gt>0].mean():.1f} ({100*ok[weak].mean():.1f})")
    print(run.name, " | ".join(out))
