"""Kitchen-a (K526) at 320, seed 0: where Regions loses to ACMM within 5%, by prior class."""
import pathlib, sys, warnings, pickle
import numpy as np
import mvscope
from PIL import Image

room = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/s16/k526/rgbd/kitchen-a")
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)

def truth(view, shape, suffix=".pfm"):
    p = room / "gt" / f"{view.scene_index:08d}{suffix}"
    g = mvscope.read_pfm(p) if suffix == ".pfm" else np.asarray(Image.open(p)) > 0
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * g.shape[0] / shape[0]), 0, g.shape[0] - 1).astype(int)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * g.shape[1] / shape[1]), 0, g.shape[1] - 1).astype(int)
    return g[np.ix_(rows, cols)]

out = {}
for method in ("acmm", "regions"):
    s = mvscope.Session(scene, method=method, seed=0)
    last = s.num_levels - 1
    ends = {}
    for st in s.steps:
        if st["level"] == last:
            ends[st["stage"]] = st["index"] + 1
    print(method, list(ends.items()), flush=True)
    stages = {}
    for stage, cur in sorted(ends.items(), key=lambda i: i[1]):
        s.goto(cur)
        stages[stage] = [dict(s.maps(v.index)) for v in scene.views]
    out[method] = stages
with open("/tmp/s19/ka_maps.pkl", "wb") as f:
    pickle.dump(out, f)
print("saved")
