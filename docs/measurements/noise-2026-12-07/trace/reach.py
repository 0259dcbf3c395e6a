import sys, pathlib, warnings, numpy as np, matplotlib
matplotlib.use("Agg"); import matplotlib.pyplot as plt
import mvscope
room = pathlib.Path(sys.argv[1]); sets = sys.argv[2:]
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
def resized(path, shape):
    a = mvscope.read_pfm(path) if path.suffix == ".pfm" else plt.imread(path) > 0
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0]), 0, a.shape[0] - 1)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1]), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]
s = mvscope.Session(scene, method="regions", seed=0, params={k: v for k, v in (a.split("=") for a in sets)})
last = s.num_levels - 1
s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
tag = "on" if sets else "off"
tot = {}
for v in scene.views:
    m, mesh = s.maps(v.index), s.prior_mesh(v.index)
    gt = resized(room / "gt" / f"{v.scene_index:08d}.pfm", (m.height, m.width))
    weak = resized(room / "gt" / f"{v.scene_index:08d}_lowtex.png", (m.height, m.width)) & (gt > 0)
    r = mesh["regions"]
    rows, cols = np.arange(m.height)[:, None] // r["cell"], np.arange(m.width) // r["cell"]
    region, plane = r["region"][rows, cols], r["plane"][rows, cols]
    prior = m["prior_depth"]
    right = (prior > 0) & (np.abs(prior - gt) <= 0.02 * gt)
    masks = {
        "prior within 2%": right, "prior wrong": (prior > 0) & ~right,
        "flat, no plane": (prior <= 0) & (region > 0) & (plane < 0),
        "flat, plane out of range": (prior == -2) & (plane >= 0),
        "not flat, out of range": (prior == -2) & (region == 0),
        "not flat, dropped": (prior == -1) & (region == 0),
        "not flat, past hull": (prior == 0) & (region == 0),
    }
    flat_cells = int((r["region"] > 0).sum()); nreg = int(r["region"].max())
    planes = r["planes"]
    print(f"view {v.index}: flat cells {flat_cells}/{r['region'].size}, regions {nreg}, planes {len(planes)}, sizes top {sorted(r['sizes'], reverse=True)[:6]}, points {len(mesh['points'])}")
    print("   weak: " + ", ".join(f"{k} {int((mk & weak).sum())}" for k, mk in masks.items()))
    # weak pixels in regions vs not
    print(f"   weak in a flat region {int((weak & (region > 0)).sum())}/{int(weak.sum())}; right among flat {int((right & weak & (region>0)).sum())}, among not flat {int((right & weak & (region==0)).sum())}")
    for k, mk in masks.items(): tot[k] = tot.get(k, 0) + int((mk & weak).sum())
    img = v.image() / 255.0 * 0.35
    col = {"prior within 2%": (0.1,0.7,0.2), "prior wrong": (0.9,0.1,0.1), "flat, no plane": (0.2,0.3,0.9), "not flat, dropped": (1,0.6,0), "not flat, past hull": (0.5,0.5,0.5)}
    for k, c in col.items(): img[masks[k] & weak] = c
    # region borders
    b = np.zeros_like(region, bool); b[:, 1:] |= region[:, 1:] != region[:, :-1]; b[1:] |= region[1:] != region[:-1]
    img[b & (region > 0)] = (1, 1, 1)
    plt.imsave(f"/tmp/s47/ana/reach-{tag}-{v.index}.png", np.repeat(np.repeat(img, 2, 0), 2, 1))
    np.save(f"/tmp/s47/ana/region-{tag}-{v.index}.npy", r["region"])
print("total", tot)
