import sys, pathlib, warnings, numpy as np
import mvscope
room = pathlib.Path(sys.argv[1]); vi = int(sys.argv[2]); x0, x1, y0, y1 = map(int, sys.argv[3].split(',')); sets = sys.argv[4:]
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0, params={k: v for k, v in (a.split("=") for a in sets)})
v = scene.views[vi]
gt0 = mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm")
ends = {}
for st in s.steps:
    ends[(st["level"], st["stage"])] = st["index"]
for (level, stage), idx in sorted(ends.items(), key=lambda kv: kv[1]):
    s.goto(idx + 1)
    m = s.maps(vi)
    H0, W0 = gt0.shape; hh, ww = m.height, m.width
    gt = gt0[np.ix_(np.clip(np.floor((np.arange(hh) + 0.5) * H0 / hh), 0, H0 - 1).astype(int), np.clip(np.floor((np.arange(ww) + 0.5) * W0 / ww), 0, W0 - 1).astype(int))]
    f = ww / 320
    sl = (slice(int(y0 * f), int(y1 * f)), slice(int(x0 * f), int(x1 * f)))
    d = m["depth"][sl]; g = gt[sl]; e = (d - g) / g
    print(f"scale {level + 1} {stage:<16} ({ww}x{hh}) section within 1% {np.mean(np.abs(e) < 0.01):.3f}, 2% {np.mean(np.abs(e) < 0.02):.3f}, median {np.median(e):+.4f}", flush=True)
