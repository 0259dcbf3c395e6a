"""Regions on kitchen-a (focal 526.5, principal points corrected) at 320, seed 0: view 3's
region planes, how right each is over the cells it paints, and Regions' and ACMM's final
depths there (ACMM's from `mvscope run --method acmm` on the same copy)."""
import sys
import numpy as np
import mvscope

GT = "/tmp/scenes/extra/rgbd/kitchen-a526pp"
ACMM = "/tmp/s43/k320-kitchen-a526pp-acmm"
VIEW = 3
scene = mvscope.Scene.open(GT, max_image_size=320)
g = mvscope.read_pfm(f"{GT}/gt/{VIEW:08}.pfm")
s = mvscope.Session(scene, method="regions", seed=0)
s.run()
m = s.prior_mesh(VIEW)
r = m["regions"]
K = scene[VIEW].K
h, w = m["height"], m["width"]
gy = np.arange(h) * g.shape[0] // h
gx = np.arange(w) * g.shape[1] // w
truth = g[gy][:, gx]
depth = s.maps(VIEW)["depth"]
acmm = mvscope.read_pfm(f"{ACMM}/depth/{VIEW:08}.pfm")
ok_all = truth > 0
rel = lambda d, msk: np.abs(d - truth)[msk] / truth[msk]
print(f"view {VIEW}: Regions within 2% {np.mean(rel(depth, ok_all) <= 0.02):.3f}, ACMM {np.mean(rel(acmm, ok_all) <= 0.02):.3f}")
c = r["cell"]
painted = np.zeros((h, w), bool)
ys, xs = np.mgrid[0:h, 0:w]
rays = np.stack([(xs - K[0, 2]) / K[0, 0], (ys - K[1, 2]) / K[1, 1], np.ones_like(xs, float)], -1)
print(f"{len(r['planes'])} planes")
for k, p in enumerate(r["planes"]):
    cells = np.argwhere(r["plane"] == k)
    if len(cells) == 0:
        continue
    n, wv = p["plane"][:3], p["plane"][3]
    mask = np.zeros((h, w), bool)
    for cy, cx in cells:
        mask[cy * c:(cy + 1) * c, cx * c:(cx + 1) * c] = True
    painted |= mask
    d = -wv / (rays @ n)
    ok = mask & ok_all
    if ok.sum() == 0:
        continue
    xs_ = cells[:, 1] * c
    ys_ = cells[:, 0] * c
    print(f"  plane {k} region {p['region']} inliers {len(p['inliers'])} pixels {ok.sum()} "
          f"x {xs_.min()}-{xs_.max() + c} y {ys_.min()}-{ys_.max() + c}: plane within 2% {np.mean(rel(d, ok) <= 0.02):.3f}, "
          f"median plane/truth {np.median(d[ok] / truth[ok]):.3f}; final within 2%: Regions {np.mean(rel(depth, ok) <= 0.02):.3f}, ACMM {np.mean(rel(acmm, ok) <= 0.02):.3f}")
rest = ~painted & ok_all
print(f"pixels no plane paints: {rest.sum()} ({rest.sum() / ok_all.sum():.3f}); within 2%: Regions {np.mean(rel(depth, rest) <= 0.02):.3f}, ACMM {np.mean(rel(acmm, rest) <= 0.02):.3f}")
