import numpy as np, sys, os
exec(open('ana.py').read().split('scene=sys.argv')[0])
from PIL import Image
scene,run=sys.argv[1],sys.argv[2]; C=5
tot={}
for v in range(10):
    gt=pfm(f'{scene}/gt/{v:08d}.pfm'); lt=np.array(Image.open(f'{scene}/gt/{v:08d}_lowtex.png'))>127
    d=pfm(f'{run}/depth/{v:08d}.pfm'); c=pfm(f'{run}/cost/{v:08d}.pfm'); k=pfm(f'{run}/confidence/{v:08d}.pfm')
    H,W=d.shape; g=gt[::2,::2][:H,:W]; l=lt[::2,::2][:H,:W]
    right=(np.abs(d-g)<0.02*g)&(g>0)
    for y0 in range(0,H-C+1,C):
        for x0 in range(0,W-C+1,C):
            sl=(slice(y0,y0+C),slice(x0,x0+C)); gg=g[sl]
            if (gg>0).sum()<C*C: continue
            weak=l[sl].mean()>0.5
            cc=c[sl].ravel(); kk=k[sl].ravel(); rr=right[sl].ravel()
            i_cost=np.argmin(cc)
            # highest confidence, ties by cost
            i_conf=np.lexsort((cc,-kk))[0]
            for name,i,ok in [('cost',i_cost,cc[i_cost]<0.1),('cost<0.3',i_cost,cc[i_cost]<0.3),('conf>=1',i_conf,kk[i_conf]>=1),('conf>=2',i_conf,kk[i_conf]>=2),('conf>=3',i_conf,kk[i_conf]>=3),('any right',0,rr.any())]:
                if not ok: continue
                key=(name,weak); a=tot.setdefault(key,[0,0]); a[0]+=1; a[1]+=(rr.any() if name=='any right' else rr[i])
for w in [False,True]:
    print('weak cells' if w else 'textured cells')
    for name in ['cost','cost<0.3','conf>=1','conf>=2','conf>=3','any right']:
        n,r=tot.get((name,w),[0,0]); print(f'  {name:10s} cells with a point {n:6d}  right {100*r/max(n,1):5.1f}%')
