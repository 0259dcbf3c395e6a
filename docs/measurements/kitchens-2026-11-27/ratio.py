import numpy as np, sys, os
exec(open('ana.py').read().split('scene=sys.argv')[0])
scene,run=sys.argv[1],sys.argv[2]
r=[]
for v in range(100):
    p=f'{scene}/gt/{v:08d}.pfm'
    if not os.path.exists(p) or not os.path.exists(f'{run}/depth/{v:08d}.pfm'): continue
    gt=pfm(p); d=pfm(f'{run}/depth/{v:08d}.pfm'); H,W=d.shape; sy=gt.shape[0]//H; sx=gt.shape[1]//W
    g=gt[::sy,::sx][:H,:W]; ok=(g>0)&(d>0)&np.isfinite(d)
    r.append(np.median(d[ok]/g[ok]))
print(run, ' '.join(f'{x:.3f}' for x in r))
