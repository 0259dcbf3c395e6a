import sys, pathlib, numpy as np
from PIL import Image
exec(open(pathlib.Path(__file__).with_name("flat.py")).read().split("def spread")[0].split("from PIL import Image")[1])
def box(a, r): return uniform_filter(a, 2*r+1)
def stats(g, r=5):
    h, w = g.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(float)
    m = box(g, r); var = np.maximum(box(g*g, r) - m*m, 0)
    cx = box(g*xx, r) - m*box(xx, r); cy = box(g*yy, r) - m*box(yy, r)
    vx = r*(r+1)/3.0
    res = np.maximum(var - cx*cx/vx - cy*cy/vx, 0)
    slope = np.hypot(cx/vx, cy/vx)
    return np.sqrt(var), np.sqrt(res), slope
for room in sys.argv[1:]:
    room = pathlib.Path(room); ims = sorted((room/"images").glob("*"))
    sl = []
    for k, p in enumerate(ims[:10]):
        im = Image.open(p).convert("L"); s = 320/max(im.size)
        if s < 1: im = im.resize((round(im.size[0]*s), round(im.size[1]*s)), Image.BOX)
        g = np.asarray(im, float); sp, rs, slope = stats(g)
        new = (sp >= 3) & (rs < 3)
        sl.append(slope[new])
    sl = np.concatenate(sl)
    q = np.percentile(sl, [10, 25, 50, 75, 90])
    print(f"{room.name:<14} newly flat {len(sl)}: slope grey/px p10..p90 " + " ".join(f"{v:.2f}" for v in q), " share<0.5: %.0f%% <0.75: %.0f%%" % (100*(sl<0.5).mean(), 100*(sl<0.75).mean()))
