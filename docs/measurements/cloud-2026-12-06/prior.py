import pickle, numpy as np, mvscope, sys
sys.path.insert(0, "/tmp/diag"); exec(open("/tmp/diag/conf.py").read().split("C = {m")[0])
sc = mvscope.Scene.open(room, max_image_size=320, views=[0,3,4])
s = mvscope.Session(sc, method="regions", seed=0)
last = s.num_levels - 1
end = max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1
s.goto(end)
out = {}
for v in views:
    i = v["index"]; mesh = s.prior_mesh(i); m = s.maps(i); r = mesh["regions"]
    out[i] = dict(prior_depth=m["prior_depth"], depth=m["depth"], cell=r["cell"], region=r["region"], plane=r["plane"], planes=r["planes"], inliers=r.get("inliers"), sizes=r["sizes"], points=mesh["points"], point_depth=mesh["point_depth"], axis=r.get("axis"))
    print(i, "cell", r["cell"], "regions", len(r["sizes"]), "planes", len(r["planes"]), "painted", (m["prior_depth"] > 0).mean())
pickle.dump(out, open(D + "/prior.pkl", "wb"))
