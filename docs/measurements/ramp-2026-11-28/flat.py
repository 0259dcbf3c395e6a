import sys, pathlib, numpy as np
from PIL import Image

def uniform_filter(a, k, mode=None):
    r = k // 2
    p = np.pad(a, r, mode="edge")
    c = p.cumsum(0).cumsum(1); c = np.pad(c, ((1,0),(1,0)))
    h, w = a.shape
    return (c[k:k+h, k:k+w] - c[0:h, k:k+w] - c[k:k+h, 0:w] + c[0:h, 0:w]) / (k*k)
def convolve(g, k):
    out = np.zeros_like(g)
    h, w = g.shape
    for dy in range(3):
        for dx in range(3):
            out[1:-1,1:-1] += k[dy,dx] * g[dy:h-2+dy, dx:w-2+dx]
    return out
def spread(g, r=5):
    m = uniform_filter(g, 2*r+1, mode="nearest"); mm = uniform_filter(g*g, 2*r+1, mode="nearest")
    return np.sqrt(np.maximum(mm - m*m, 0))
def noise(g):  # Immerkaer 1996
    k = np.array([[1,-2,1],[-2,4,-2],[1,-2,1]], float)
    c = convolve(g, k)[1:-1,1:-1]
    return np.sqrt(np.pi/2) * np.abs(c).sum() / (6*(g.shape[0]-2)*(g.shape[1]-2))
for room in sys.argv[1:]:
    room = pathlib.Path(room)
    ims = sorted((room/"images").glob("*"))
    fl, flw, ns = [], [], []
    for p in ims:
        im = Image.open(p).convert("L")
        s = 320 / max(im.size)
        if s < 1: im = im.resize((round(im.size[0]*s), round(im.size[1]*s)), Image.BOX)
        g = np.asarray(im, float)
        sp = spread(g)
        wk = room/"gt"/(f"{ims.index(p):08d}_lowtex.png")
        w = np.asarray(Image.open(wk).resize(im.size, Image.NEAREST)) > 0 if wk.exists() else None
        fl.append((sp < 3).mean()); ns.append(noise(g))
        if w is not None: flw.append((sp[w] < 3).mean())
    print(f"{room.name:<20} flat {100*np.mean(fl):5.1f}%  weak-and-flat/weak {100*np.mean(flw) if flw else float('nan'):5.1f}%  noise sigma {np.mean(ns):.2f} ({min(ns):.2f}-{max(ns):.2f})")
