import pickle, numpy as np, mvscope, sys
sys.path.insert(0, "/tmp/diag"); exec(open("/tmp/diag/conf.py").read().split("C = {m")[0])
sc = mvscope.Scene.open(room, max_image_size=320, views=[0,3,4])
rows = []
for v in views:
    i = v["index"]; g = gt_at(v)
    ea = np.abs(d["out"]["acmm"]["maps"][i]["depth"] - g) / np.where(g > 0, g, 1)
    er = np.abs(d["out"]["regions"]["maps"][i]["depth"] - g) / np.where(g > 0, g, 1)
    im = np.asarray(sc.views[i].gray()).astype(float); im = (im / im.max() * 255 * 0.6)
    img = np.stack([im] * 3, -1).astype(np.uint8)
    img[(g > 0) & (ea <= .02) & (er > .05)] = (255, 40, 40)
    img[(g > 0) & (er <= .02) & (ea > .05)] = (60, 140, 255)
    img[(g > 0) & (ea <= .02) & (er > .02) & (er <= .05)] = (255, 170, 0)
    img[(g > 0) & (er <= .02) & (ea > .02) & (ea <= .05)] = (0, 220, 220)
    print(i, "A ok R >5%:", ((g > 0) & (ea <= .02) & (er > .05)).sum(), " R ok A >5%:", ((g > 0) & (er <= .02) & (ea > .05)).sum(),
          " A ok R 2-5:", ((g > 0) & (ea <= .02) & (er > .02) & (er <= .05)).sum(), " R ok A 2-5:", ((g > 0) & (er <= .02) & (ea > .02) & (ea <= .05)).sum())
    rows.append(np.repeat(np.repeat(img, 2, 0), 2, 1))
write_png(D + "/diff.png", np.concatenate(rows[1:], 1))
write_png(D + "/diff0.png", rows[0])
