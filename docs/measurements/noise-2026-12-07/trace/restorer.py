import sys, pathlib, warnings, numpy as np
import mvscope
room = pathlib.Path(sys.argv[1]); vi = int(sys.argv[2]); sets = sys.argv[3:]
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
s = mvscope.Session(scene, method="regions", seed=0, params={k: v for k, v in (a.split("=") for a in sets)})
last = s.num_levels - 1
steps = s.steps
prior_steps = [st for st in steps if (st["level"], st["stage"]) == (last, "planar prior")]
print("prior stage steps:", [(st["index"], st.get("name", st.get("label"))) for st in prior_steps][:12])
first = min(st["index"] for st in prior_steps)
s.goto(first)
v = scene.views[vi]
gt = mvscope.read_pfm(room / "gt" / f"{v.scene_index:08d}.pfm")
m = s.maps(vi)
print("maps:", [k for k in m.keys()] if hasattr(m, "keys") else dir(m))
d = m["depth"]; c = m["cost"]
err = np.abs(d - gt) / np.maximum(gt, 1e-9)
low = None
for name, (x0, x1, y0, y1) in {"left section": (60, 110, 20, 110), "middle section": (125, 180, 20, 105), "right": (195, 230, 15, 145)}.items():
    e = err[y0:y1, x0:x1]; cc = c[y0:y1, x0:x1]
    # min-cost pixel per 5x5 cell
    H, W = e.shape; ce = []
    for yy in range(0, H - 4, 5):
        for xx in range(0, W - 4, 5):
            blk = cc[yy:yy+5, xx:xx+5]; k = np.unravel_index(np.argmin(blk), blk.shape); ce.append(e[yy:yy+5, xx:xx+5][k])
    ce = np.array(ce)
    print(f"{name}: restorer pixels within 1% {np.mean(e<0.01):.3f}, 2% {np.mean(e<0.02):.3f}; cost median {np.median(cc):.3f}; per-cell min-cost pixel within 1% {np.mean(ce<0.01):.3f}, 2% {np.mean(ce<0.02):.3f}; median signed err {np.median(((d-gt)/gt)[y0:y1, x0:x1]):.4f}")
