import pathlib, sys, warnings, numpy as np, mvscope
from PIL import Image
room = pathlib.Path("/work/shared/data/middlebury2006/Flowerpots")
warnings.simplefilter("ignore", mvscope.SceneWarning)
scene = mvscope.Scene.open(room, max_image_size=320)
def truth(view, shape):
    g = mvscope.read_pfm(room / "gt" / f"{view.scene_index:08d}.pfm")
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * g.shape[0] / shape[0]), 0, g.shape[0] - 1).astype(int)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * g.shape[1] / shape[1]), 0, g.shape[1] - 1).astype(int)
    return g[np.ix_(rows, cols)]
res = {}
for name, params in (("reg", {}), ("ramp", {"prior_flat_ramp": True})):
    s = mvscope.Session(scene, method="regions", seed=0, params=params)
    last = s.num_levels - 1
    ends = {}
    for st in s.steps:
        if st["level"] == last: ends[st["stage"]] = st["index"] + 1
    s.goto(ends["planar prior"]); pp = s.maps(0)
    s.run(); fin = s.maps(0)
    res[name] = (pp, fin)
v = scene.views[0]
d0 = res["reg"][1]["depth"]; g = truth(v, d0.shape); val = g > 0
ok = lambda d: (d > 0) & (np.abs(d - g) <= 0.02 * g) & val
a, b = ok(res["reg"][1]["depth"]), ok(res["ramp"][1]["depth"])
pa, pb = res["reg"][0]["prior_depth"] > 0, res["ramp"][0]["prior_depth"] > 0
pra, prb = ok(res["reg"][0]["prior_depth"]), ok(res["ramp"][0]["prior_depth"])
print("view0 right: reg %.1f ramp %.1f" % (100*a.sum()/val.sum(), 100*b.sum()/val.sum()))
print("prior cover: reg %.1f ramp %.1f; prior right of cover: reg %.1f ramp %.1f" % (100*pa.mean(), 100*pb.mean(), 100*pra.sum()/max(pa.sum(),1), 100*prb.sum()/max(pb.sum(),1)))
lost = a & ~b; won = b & ~a
print("lost", lost.sum(), "won", won.sum(), "lost with ramp prior", (lost & pb).sum(), "of which prior wrong", (lost & pb & ~prb).sum(), "lost where reg had no prior", (lost & ~pa).sum())
img = np.asarray(Image.open(sorted((room/"images").glob("*"))[v.scene_index]).convert("RGB").resize((d0.shape[1], d0.shape[0])), float) / 255
ov = img * 0.5
ov[lost] = (1, 0.1, 0.1); ov[won] = (0.1, 1, 0.1)
ov2 = img * 0.5
ov2[pb & ~prb] = (1, 0.1, 1); ov2[pb & prb] = (0.1, 0.6, 1)
Image.fromarray((np.concatenate([ov, ov2], 1) * 255).astype(np.uint8)).resize((d0.shape[1]*4, d0.shape[0]*2)).save("/tmp/s19/fp.png")
