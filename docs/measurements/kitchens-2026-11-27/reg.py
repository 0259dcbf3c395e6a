# Resample a 7-Scenes truth (depth camera grid, focal FD) onto the colour image's grid (focal FC),
# both centred at (cx, cy), sharing the camera centre: colour pixel p sees the ray of depth pixel
# q = c + (p - c) * FD / FC; z is unchanged. Nearest neighbour (no mixing across edges).
import numpy as np, sys, os, shutil
def rpfm(p):
    with open(p,'rb') as f:
        h=f.readline().strip(); w,hh=map(int,f.readline().split()); s=float(f.readline())
        d=np.frombuffer(f.read(),dtype='<f4' if s<0 else '>f4').reshape(hh,w)
    return np.flipud(d).copy()
def wpfm(p,d):
    with open(p,'wb') as f:
        f.write(b'Pf\n%d %d\n-1.0\n'%(d.shape[1],d.shape[0])); f.write(np.flipud(d).astype('<f4').tobytes())
src,dst,FD,FC=sys.argv[1],sys.argv[2],float(sys.argv[3]),float(sys.argv[4])
os.makedirs(dst+'/gt',exist_ok=True); os.makedirs(dst+'/cams',exist_ok=True)
if not os.path.exists(dst+'/images'): os.symlink(os.path.abspath(src)+'/images',dst+'/images')
shutil.copy(src+'/pair.txt',dst+'/pair.txt')
for fn in sorted(os.listdir(src+'/cams')):
    t=open(src+'/cams/'+fn).read().replace('%.10f'%FD,'%.10f'%FC); open(dst+'/cams/'+fn,'w').write(t)
for fn in sorted(os.listdir(src+'/gt')):
    if fn.endswith('_lowtex.png'): shutil.copy(src+'/gt/'+fn,dst+'/gt/'+fn); continue
    if not fn.endswith('.pfm') or '_' in fn: continue
    g=rpfm(src+'/gt/'+fn); H,W=g.shape; cx,cy=W/2,H/2
    v,u=np.mgrid[0:H,0:W].astype(np.float64)
    qu=np.rint(cx+(u-cx)*FD/FC).astype(int); qv=np.rint(cy+(v-cy)*FD/FC).astype(int)
    ok=(qu>=0)&(qu<W)&(qv>=0)&(qv<H)
    out=np.zeros_like(g); out[ok]=g[qv[ok],qu[ok]]
    wpfm(dst+'/gt/'+fn,out)
    print(fn, 'truth on', ok.mean().round(3), 'of pixels, valid', (out>0).mean().round(3))
