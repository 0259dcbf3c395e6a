import sys, time, pickle
import numpy as np, mvscope
from pathlib import Path
import os; room = Path(os.environ.get("ROOM", "/work/shared/data/rgbd/icl-livingroom")); D = os.environ.get("D", "/tmp/diag")
scene = mvscope.Scene.open(room, max_image_size=320, views=[0, 3, 4])
out = {}
for method in ["acmm", "regions"]:
    t = time.time()
    s = mvscope.Session(scene, method=method, seed=0)
    s.run()
    cloud = s.fuse()
    maps = {v.index: {k: s.maps(v.index)[k] for k in ["depth", "normal", "cost"]} for v in scene.views}
    out[method] = dict(points=np.asarray(cloud.points), maps=maps)
    print(method, len(cloud.points), f"{time.time()-t:.1f}s", flush=True)
views = [dict(index=v.index, si=v.scene_index, K=np.asarray(v.K), R=np.asarray(v.R), t=np.asarray(v.t), w=v.width, h=v.height) for v in scene.views]
pickle.dump(dict(out=out, views=views), open(D + "/runs.pkl", "wb"))
