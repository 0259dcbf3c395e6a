import pickle, numpy as np, mvscope, sys
sys.path.insert(0, "/tmp/diag"); exec(open("/tmp/diag/conf.py").read().split("C = {m")[0])
P = pickle.load(open(D + "/prior.pkl", "rb"))
pal = np.array([(230,25,75),(60,180,75),(255,225,25),(0,130,200),(245,130,48),(145,30,180),(70,240,240),(240,50,230)], np.uint8)
for i in [1, 2]:
    v = views[i]; p = P[i]; g = gt_at(v); h, w = g.shape
    print(i, "planes", p["planes"], "sizes", p["sizes"])
    cell = p["cell"]; ys, xs = np.mgrid[0:h, 0:w]
    pl = p["plane"][ys // cell, xs // cell]; rg = p["region"][ys // cell, xs // cell]
    a = np.zeros((h, w, 3), np.uint8) + 30
    a[pl >= 0] = pal[pl[pl >= 0] % 8]
    a[(rg > 0) & (pl < 0)] = (120, 120, 120)
    pe = np.abs(p["prior_depth"] - g) / np.where(g > 0, g, 1)
    b = np.zeros((h, w, 3), np.uint8) + 30
    has = (p["prior_depth"] > 0) & (g > 0)
    b[has & (pe <= .01)] = (0, 200, 0); b[has & (pe > .01) & (pe <= .02)] = (150, 220, 0); b[has & (pe > .02) & (pe <= .05)] = (230, 180, 0); b[has & (pe > .05)] = (220, 30, 30)
    # per plane: error of its painted pixels
    for k in range(len(p["planes"])):
        sel = has & (pl == k)
        if sel.sum(): print("  plane", k, "pixels", sel.sum(), "within2 %.2f" % (pe[sel] <= .02).mean(), "within5 %.2f" % (pe[sel] <= .05).mean(), "median rel err %.3f" % np.median((p["prior_depth"][sel] - g[sel]) / g[sel]))
    write_png(D + f"/prior{i}.png", np.repeat(np.repeat(np.concatenate([a, b], 1), 2, 0), 2, 1))
