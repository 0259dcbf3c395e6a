import numpy as np, sys, os
from PIL import Image
def pfm(p):
    with open(p,'rb') as f:
        h=f.readline().strip(); w,hh=map(int,f.readline().split()); s=float(f.readline())
        d=np.frombuffer(f.read(),dtype='<f4' if s<0 else '>f4')
    c=3 if h==b'PF' else 1
    d=d.reshape(hh,w,c) if c==3 else d.reshape(hh,w)
    return np.flipud(d).copy()
scene=sys.argv[1]; runs=sys.argv[2:]
n=len(os.listdir(f'{scene}/cams'))
tot={r:[0,0,0] for r in runs}
for v in range(n):
    gt=pfm(f'{scene}/gt/{v:08d}.pfm'); lt=np.array(Image.open(f'{scene}/gt/{v:08d}_lowtex.png'))>127
    line=f'view {v}:'
    for r in runs:
        d=pfm(f'{r}/depth/{v:08d}.pfm'); H,W=d.shape; sy=gt.shape[0]//H; sx=gt.shape[1]//W
        g=gt[::sy,::sx][:H,:W]; l=lt[::sy,::sx][:H,:W]
        ok=g>0; e=np.abs(d-g)/np.maximum(g,1e-9)
        w2=(e<0.02)&ok; wk=ok&l
        rat=np.median(d[wk]/g[wk]) if wk.sum() else 0
        line+=f'  {os.path.basename(r)}: all {100*w2.sum()/ok.sum():5.1f} weak {100*(w2&l).sum()/max(wk.sum(),1):5.1f} (n={wk.sum()}) med ratio weak {rat:.3f} |e|<5% weak {100*((e<0.05)&wk).sum()/max(wk.sum(),1):5.1f}'
        tot[r][0]+=w2.sum(); tot[r][1]+=ok.sum(); tot[r][2]+=0
    print(line)
