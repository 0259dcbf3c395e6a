# Draw boxes (x0 x1 y0 y1 at the run's 320-px size) on a view's image. Usage: boxes.py IMAGE OUT.png "x0,x1,y0,y1,colour" ...
import sys, numpy as np, matplotlib
matplotlib.use("Agg"); import matplotlib.pyplot as plt
from PIL import Image
im = Image.open(sys.argv[1]); s = 320 / max(im.size); im = im.resize((round(im.size[0] * s), round(im.size[1] * s)))
fig, ax = plt.subplots(figsize=(im.size[0] / 50, im.size[1] / 50), dpi=100); ax.imshow(im); ax.axis("off")
for b in sys.argv[3:]:
    x0, x1, y0, y1, c = b.split(","); x0, x1, y0, y1 = map(float, (x0, x1, y0, y1))
    ax.add_patch(plt.Rectangle((x0, y0), x1 - x0 + 1, y1 - y0 + 1, fill=False, ec=c, lw=2))
fig.savefig(sys.argv[2], bbox_inches="tight"); print("wrote", sys.argv[2])
