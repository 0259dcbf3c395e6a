"""Step ACMM scale by scale on the synthetic scene and show, at each scale, the depth map
and the detail restorer's C_init − C_photo (where it exceeds ξ the upsampled plane was an
error in the details and the restorer replaced it).

    python python/examples/scale_by_scale.py --out scales.png            # 320x240, 5 views
    python python/examples/scale_by_scale.py --small --out scales.png    # CI: 96x72, 3 views
"""

import argparse
import pathlib
import tempfile

import matplotlib

matplotlib.use("Agg")  # write a file; in a notebook, leave this out
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import TwoSlopeNorm

import mvscope

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--out", default="scale_by_scale.png", help="the figure")
parser.add_argument("--small", action="store_true", help="a quick run: 96x72, 3 views")
args = parser.parse_args()

folder = pathlib.Path(tempfile.mkdtemp()) / "demo"
if args.small:
    scene = mvscope.demo(folder, views=3, width=96, height=72)
else:
    scene = mvscope.demo(folder, views=5, width=320, height=240)
session = mvscope.Session(scene, method="acmm", seed=0)
xi = session.params["xi"]
view = 0

levels = session.num_levels
fig, axes = plt.subplots(2, levels, figsize=(4 * levels, 6), squeeze=False)
for k in range(levels):
    session.step(unit="scale")  # the viewer's "scale" button: every stage of this scale
    maps = session.maps(view)
    score = mvscope.evaluate(session, gt=folder).within(0.02)
    print(f"scale {maps.scale}/{levels}: {maps.width}x{maps.height}, "
          f"{score:.1%} of the pixels within 2% of the truth")

    depth = np.where(maps["depth"] > 0, maps["depth"], np.nan)
    ax = axes[0, k]
    ax.imshow(depth, cmap="viridis")
    ax.set_title(f"scale {maps.scale}/{levels}: depth ({maps.width}x{maps.height})")
    ax.set_axis_off()

    ax = axes[1, k]
    ax.set_axis_off()
    if "restorer_difference" not in maps:
        ax.text(0.5, 0.5, "coarsest scale:\nno detail restorer", ha="center", va="center")
        continue
    # White at ξ: red pixels exceed it (the restorer replaced their upsampled plane).
    diff = maps["restorer_difference"]
    lo, hi = min(diff.min(), xi - 1e-3), max(diff.max(), xi + 1e-3)
    norm = TwoSlopeNorm(vcenter=xi, vmin=lo, vmax=hi)
    fig.colorbar(ax.imshow(diff, cmap="coolwarm", norm=norm), ax=ax, shrink=0.8)
    replaced = maps["replaced"]
    ax.set_title(f"C_init − C_photo ({replaced.mean():.0%} > ξ = {xi:g}: replaced)")

fig.tight_layout()
fig.savefig(args.out, dpi=100)
print(f"saved {args.out}")
