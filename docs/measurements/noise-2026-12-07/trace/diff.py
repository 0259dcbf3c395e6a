import numpy as np, sys
from PIL import Image
def pfm(p):
    with open(p,'rb') as f:
        h=f.readline().strip(); w,hh=map(int,f.readline().split()); s=float(f.readline())
        d=np.frombuffer(f.read(),dtype='<f4' if s<0 else '>f4')
    c=3 if h==b'PF' else 1
    return np.flipud(d.reshape(hh,w,c) if c==3 else d.reshape(hh,w))
S='/tmp/scenes/extra/rgbd/room-n3'; R='/tmp/s47/room'
for v in range(5):
    gt=pfm(f'{S}/gt/{v:08d}.pfm'); low=np.array(Image.open(f'{S}/gt/{v:08d}_lowtex.png'))>0
    on=pfm(f'{R}/on/depth/{v:08d}.pfm'); off=pfm(f'{R}/off/depth/{v:08d}.pfm')
    if on.shape!=gt.shape: print('shape',on.shape,gt.shape)
    ok=lambda d: np.abs(d-gt)<0.02*gt
    a,b=ok(off)&(gt>0),ok(on)&(gt>0)
    lost=a&~b&low; won=b&~a&low
    h,w=gt.shape
    print(f'view {v}: weak {low.sum()} lost {lost.sum()} won {won.sum()}; lost rows top/mid/bot thirds',
          [int(lost[i*h//3:(i+1)*h//3].sum()) for i in range(3)], 'cols', [int(lost[:,i*w//3:(i+1)*w//3].sum()) for i in range(3)])
    # where lost: on error sign
    e=(on-gt)/gt
    print('   lost: on rel err median %.3f, |err| p25 %.3f p75 %.3f'%(np.median(e[lost]),*np.percentile(np.abs(e[lost]),[25,75])))
    img=np.zeros((h,w,3),np.uint8); img[low]=60; img[lost]=[255,0,0]; img[won]=[0,255,0]
    Image.fromarray(img).resize((w*2,h*2),Image.NEAREST).save(f'/tmp/s47/ana/lost{v}.png')
