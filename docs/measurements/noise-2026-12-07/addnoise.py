# Copy an ACMM-format scene folder, adding Gaussian sensor noise (sigma grey levels) to its images.
import sys, shutil, os, glob, numpy as np
from PIL import Image
src, dst, sigma = sys.argv[1], sys.argv[2], float(sys.argv[3])
shutil.copytree(src, dst, symlinks=False)
rng = np.random.default_rng(12345)
for f in sorted(glob.glob(os.path.join(dst, 'images', '*'))):
    im = Image.open(f)
    a = np.asarray(im).astype(float)
    n = rng.normal(0, sigma, a.shape[:2]); n = n[..., None] if a.ndim == 3 else n
    a = np.clip(np.round(a + n), 0, 255).astype(np.uint8)
    Image.fromarray(a, im.mode).save(f)
print('wrote', dst)
