"""A run's depth maps against the truth, as shipped and with each view's median ratio
est/gt divided out (a per-view scale the truth or cameras may carry): within 2% and 5%,
all pixels and weak texture."""
import sys, pathlib
import numpy as np
import mvscope
from truth import truth
scene = pathlib.Path(sys.argv[1])
for run in sys.argv[2:]:
    run = pathlib.Path(run)
    acc = {k: [0, 0] for k in ("a2", "a5", "w2", "w5", "sa2", "sa5", "sw2", "sw5")}
    ratios = []
    for f in sorted((run / "depth").glob("*.pfm")):
        est = np.asarray(mvscope.read_pfm(f))
        gt, weak = truth(scene, f.stem, est.shape)
        ok = gt > 0
        r = np.median(est[ok & (est > 0)] / gt[ok & (est > 0)])
        ratios.append(r)
        for pre, e in (("", est), ("s", est / r)):
            rel = np.abs(e - gt) / np.where(ok, gt, 1)
            for t, k in ((0.02, "2"), (0.05, "5")):
                for m, mk in ((ok, "a"), (ok & weak, "w")):
                    acc[pre + mk + k][0] += int(np.sum((rel <= t) & m)); acc[pre + mk + k][1] += int(np.sum(m))
    pc = lambda k: 100 * acc[k][0] / max(acc[k][1], 1)
    print(f"{run.name}: as shipped within 2% {pc('a2'):.1f} ({pc('w2'):.1f}), 5% {pc('a5'):.1f} ({pc('w5'):.1f}); "
          f"each view's median ratio divided out: 2% {pc('sa2'):.1f} ({pc('sw2'):.1f}), 5% {pc('sa5'):.1f} ({pc('sw5'):.1f}); "
          f"ratios {' '.join(f'{r:.3f}' for r in ratios)}", flush=True)
