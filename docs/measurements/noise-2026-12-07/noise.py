# Immerkaer (1996) fast noise estimate: sigma = sqrt(pi/2)/(6(W-2)(H-2)) * sum|I*N|
import numpy as np, sys, glob, os
from PIL import Image
K = np.array([[1,-2,1],[-2,4,-2],[1,-2,1]], float)
def sigma(g):
    H, W = g.shape
    c = sum(K[i,j]*g[i:H-2+i, j:W-2+j] for i in range(3) for j in range(3))
    return np.sqrt(np.pi/2)/(6*(W-2)*(H-2))*np.abs(c).sum()
def sigma_flat(g):
    # same, but only over pixels whose 3x3 gradient is small (exclude edges): Immerkaer on homogeneous areas
    H, W = g.shape
    c = sum(K[i,j]*g[i:H-2+i, j:W-2+j] for i in range(3) for j in range(3))
    gx = np.abs(g[1:-1,2:]-g[1:-1,:-2]); gy = np.abs(g[2:,1:-1]-g[:-2,1:-1])
    m = (gx+gy) < np.percentile(gx+gy, 50)
    return np.sqrt(np.pi/2)/6*np.abs(c[m]).mean()
for pat in sys.argv[1:]:
    files = sorted(glob.glob(pat))[:5]
    rows=[]
    for f in files:
        im = Image.open(f).convert('L')
        g = np.asarray(im, float)
        w, h = im.size
        s = 320/max(w,h)
        g3 = np.asarray(im.resize((round(w*s), round(h*s)), Image.BILINEAR), float)
        rows.append((sigma(g), sigma_flat(g), sigma(g3), sigma_flat(g3)))
    r = np.array(rows).mean(0)
    print(f"{pat}: full {r[0]:.2f} (flat half {r[1]:.2f})  at 320 {r[2]:.2f} ({r[3]:.2f})  n={len(files)}")
