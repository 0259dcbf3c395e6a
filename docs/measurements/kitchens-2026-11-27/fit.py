# Which registration of the Kinect truth fits the colour images best? For each candidate
# (focal of the colour camera FC, offset T of the colour camera from the depth camera, x),
# splat the truth (depth grid, 585 px) into the colour grid, warp the reference's textured
# pixels into a source with it, and report the mean absolute grey difference.
import numpy as np, sys
from PIL import Image
def rpfm(p):
    with open(p,'rb') as f:
        h=f.readline().strip(); w,hh=map(int,f.readline().split()); s=float(f.readline())
        d=np.frombuffer(f.read(),dtype='<f4' if s<0 else '>f4').reshape(hh,w)
    return np.flipud(d).copy()
def cam(scene,i):
    L=open(f'{scene}/cams/{i:08d}_cam.txt').read().split()
    E=np.array(L[1:17],float).reshape(4,4); return E[:3,:3],E[:3,3]
def grey(scene,i): return np.asarray(Image.open(f'{scene}/images/{i:08d}.png').convert('L'),np.float64)
def register(g,FD,FC,T):
    H,W=g.shape; c=np.array([W/2,H/2]); v,u=np.nonzero(g>0); z=g[v,u].astype(np.float64)
    X=np.stack([(u-c[0])/FD*z,(v-c[1])/FD*z,z],1)+np.array(T)
    pu=np.rint(c[0]+FC*X[:,0]/X[:,2]).astype(int); pv=np.rint(c[1]+FC*X[:,1]/X[:,2]).astype(int)
    ok=(pu>=0)&(pu<W)&(pv>=0)&(pv<H); out=np.full((H,W),np.inf)
    np.minimum.at(out,(pv[ok],pu[ok]),X[ok,2]); out[np.isinf(out)]=0; return out
def bil(I,x,y):
    x0=np.floor(x).astype(int); y0=np.floor(y).astype(int); fx=x-x0; fy=y-y0
    return (I[y0,x0]*(1-fx)*(1-fy)+I[y0,x0+1]*fx*(1-fy)+I[y0+1,x0]*(1-fx)*fy+I[y0+1,x0+1]*fx*fy)
def fit(scene,i,j,D,FC):
    H,W=D.shape; Ri,ti=cam(scene,i); Rj,tj=cam(scene,j); Ii=grey(scene,i); Ij=grey(scene,j)
    lt=np.asarray(Image.open(f'{scene}/gt/{i:08d}_lowtex.png'))>127
    v,u=np.nonzero((D>0)&~lt); z=D[v,u]
    Xc=np.stack([(u-W/2)/FC*z,(v-H/2)/FC*z,z],1); Xw=(Xc-ti)@Ri; Xj=Xw@Rj.T+tj
    x=W/2+FC*Xj[:,0]/Xj[:,2]; y=H/2+FC*Xj[:,1]/Xj[:,2]
    ok=(x>=0)&(x<W-1)&(y>=0)&(y<H-1)&(Xj[:,2]>0)
    return np.mean(np.abs(bil(Ij,x[ok],y[ok])-Ii[v[ok],u[ok]])), ok.sum()
scene=sys.argv[1]; pairs=[tuple(map(int,p.split(':'))) for p in sys.argv[2].split(',')]
for FC in [float(f) for f in sys.argv[3].split(',')]:
  for tx in [float(t) for t in sys.argv[4].split(',')]:
    for ty in [float(t) for t in (sys.argv[5] if len(sys.argv)>5 else '0').split(',')]:
      r=[]
      for i,j in pairs:
        D=register(rpfm(f"{scene}/gt/{i:08d}.pfm"),float(__import__("os").environ.get("FD","585")),FC,(tx,ty,0.0)); r.append(fit(scene,i,j,D,FC)[0])
      print(f'FC {FC:6.1f} T ({tx:+.3f},{ty:+.3f}): ' + ' '.join(f'{a:5.2f}' for a in r), f' mean {np.mean(r):5.2f}', flush=True)
if len(sys.argv)>6:
    for FC in [float(f) for f in sys.argv[3].split(',')]:
        r=[fit(scene,i,j,rpfm(f'{scene}/gt/{i:08d}.pfm'),FC)[0] for i,j in pairs]
        print(f'unregistered, FC {FC}: '+' '.join(f'{a:5.2f}' for a in r), f' mean {np.mean(r):5.2f}')
