import sys, pathlib, numpy as np
from PIL import Image
exec(open(pathlib.Path(__file__).with_name("flat.py")).read().split("def spread")[0].split("from PIL import Image")[1])
def box(a, r): return uniform_filter(a, 2*r+1)
def spreads(g, r=5):
    h, w = g.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(float)
    m = box(g, r); var = np.maximum(box(g*g, r) - m*m, 0)
    # centered coords within window: cov(I,x) = E[I x] - E[I]E[x]
    cx = box(g*xx, r) - m*box(xx, r); cy = box(g*yy, r) - m*box(yy, r)
    vx = r*(r+1)/3.0  # variance of uniform integers -r..r
    res = np.maximum(var - cx*cx/vx - cy*cy/vx, 0)
    return np.sqrt(var), np.sqrt(res), np.hypot(cx/vx, cy/vx)  # the ramp's slope, grey/px
for room in sys.argv[1:]:
    room = pathlib.Path(room)
    ims = sorted((room/"images").glob("*"))
    A = np.zeros(6); sl = []
    for k, p in enumerate(ims):
        im = Image.open(p).convert("L"); s = 320/max(im.size)
        if s < 1: im = im.resize((round(im.size[0]*s), round(im.size[1]*s)), Image.BOX)
        g = np.asarray(im, float); sp, rs, slope = spreads(g)
        sl.append(slope[(sp >= 3) & (rs < 3)])  # the windows the ramp makes flat
        wk = room/"gt"/f"{k:08d}_lowtex.png"
        w = np.asarray(Image.open(wk).resize(im.size, Image.NEAREST)) > 0 if wk.exists() else np.zeros(g.shape, bool)
        A += [(sp[w]<3).sum(), (rs[w]<3).sum(), w.sum(), (sp[~w]<3).sum(), (rs[~w]<3).sum(), (~w).sum()]
    print(f"{room.name:<14} weak flat: plain {100*A[0]/A[2]:5.1f}% detrended {100*A[1]/A[2]:5.1f}%   textured flat: plain {100*A[3]/A[5]:5.1f}% detrended {100*A[4]/A[5]:5.1f}%")
    sl = np.concatenate(sl)
    print(f"{'':<14} the ramp's slope where it makes a window flat, grey levels a pixel, p10/p25/p50/p75/p90: "
          + " ".join(f"{v:.2f}" for v in np.percentile(sl, [10, 25, 50, 75, 90])))
