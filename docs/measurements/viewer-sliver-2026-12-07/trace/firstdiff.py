# Where a Regions option first changes a scene's maps: two sessions (defaults and one with
# options set), stepped stage by stage together; per stage the views' depths and prior
# depths compared, and the share of the truth's pixels within 2% for each.
# Usage: firstdiff.py SCENE_DIR key=value ...
import sys, pathlib, warnings, numpy as np
import mvscope
root = pathlib.Path(sys.argv[1])
params = {}
for kv in sys.argv[2:]:
    k, v = kv.split("=")
    params[k] = {"true": True, "false": False}[v] if v in ("true", "false") else float(v)
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(root, max_image_size=320)
a = mvscope.Session(scene, method="regions", seed=0)
b = mvscope.Session(scene, method="regions", seed=0, params=params)
assert len(a.steps) == len(b.steps)
gts = {v.index: mvscope.read_pfm(root / "gt" / f"{v.scene_index:08d}.pfm") for v in scene.views}
def score(d, gt):
    # nearest-neighbour truth at the map's size
    r = (np.floor((np.arange(d.shape[0]) + 0.5) * gt.shape[0] / d.shape[0])).astype(int)
    c = (np.floor((np.arange(d.shape[1]) + 0.5) * gt.shape[1] / d.shape[1])).astype(int)
    g = gt[np.ix_(r, c)]
    ok = g > 0
    return float(((np.abs(d - g) <= 0.02 * g) & ok).sum() / max(ok.sum(), 1))
while not a.finished:
    a.step(unit="stage"); b.step(unit="stage")
    st = a.steps[a.cursor - 1]
    line = []
    for v in scene.views:
        ma, mb = a.maps(v.index), b.maps(v.index)
        dd = int((ma["depth"] != mb["depth"]).sum())
        pd = int((ma["prior_depth"] != mb["prior_depth"]).sum()) if "prior_depth" in ma else -1
        line.append(f"v{v.index}: depth diff {dd} prior diff {pd} within2% {score(ma['depth'], gts[v.index]):.3f}/{score(mb['depth'], gts[v.index]):.3f}")
    print(f"{st['label']}: " + "; ".join(line), flush=True)
