"""Reads dump.py's .npz and kitchen-a's images. orient.py found no reliable pixels' normal
near kitchen-a's wall. Do the image's straight lines give it? Per view, line segments
(OpenCV's LSD, 30 px or longer, full-size image) and the Manhattan frame most of them fit
(three orthogonal vanishing directions by RANSAC: two lines give one direction, a third line
the second, their cross product the third; a line fits a direction whose angle to its
interpretation plane is under 1.5 deg). How far is the frame's nearest axis from the wall's
truth normal, and what does each region hold within 2% with the axis its points fit best
(their median offset, as orient.py)?"""
import sys
import numpy as np
import cv2
from wallfit import largest_region

z = np.load(sys.argv[1] if len(sys.argv) > 1 else "/tmp/wall-dump.npz")
root = sys.argv[2] if len(sys.argv) > 2 else "/tmp/s30/kroot/rgbd/kitchen-a"
nv = int(z["views"])
rng = np.random.default_rng(0)
sin_tol = np.sin(np.radians(1.5))


def full_K(v):
    rows = open(f"{root}/cams/{v:08d}_cam.txt").read().split("\n")[7:10]
    return np.array([[float(x) for x in r.split()] for r in rows])


def interpretation_planes(v):
    img = cv2.imread(f"{root}/images/{v:08d}.png", cv2.IMREAD_GRAYSCALE)
    segs = cv2.createLineSegmentDetector().detect(img)[0].reshape(-1, 4)
    segs = segs[np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]) >= 30]
    Ki = np.linalg.inv(full_K(v))
    a = (Ki @ np.c_[segs[:, :2], np.ones(len(segs))].T).T
    b = (Ki @ np.c_[segs[:, 2:], np.ones(len(segs))].T).T
    l = np.cross(a, b)
    return l / np.linalg.norm(l, axis=1, keepdims=True), segs


def manhattan(l, iters=4000):
    best = (-1, None)
    for _ in range(iters):
        i, j, k = rng.choice(len(l), 3, replace=False)
        d1 = np.cross(l[i], l[j])
        if np.linalg.norm(d1) < 1e-6: continue
        d1 /= np.linalg.norm(d1)
        d2 = np.cross(l[k], d1)
        if np.linalg.norm(d2) < 1e-6: continue
        d2 /= np.linalg.norm(d2)
        F = np.stack([d1, d2, np.cross(d1, d2)])
        fit = (np.abs(l @ F.T) < sin_tol).any(1).sum()
        if fit > best[0]: best = (fit, F)
    return best


def wall(v):
    r = largest_region(z, v)
    return r["normal"], r["rays"], r["gt"], r["point_rays"], r["point_depth"]

def rotation(v):
    rows = open(f"{root}/cams/{v:08d}_cam.txt").read().split("\n")[1:4]
    return np.array([[float(x) for x in r.split()] for r in rows])[:, :3]


pooled = len(sys.argv) > 3 and sys.argv[3] == "pooled"
if pooled:
    # one frame for the scene: every view's interpretation planes turned into the world
    world = np.concatenate([(rotation(v).T @ interpretation_planes(v)[0].T).T for v in range(nv)])
    wfit, WF = manhattan(world, 8000)
    print(f"pooled: {len(world)} segments over {nv} views, {wfit} fit one world frame")
held = []
for v in range(nv):
    l, segs = interpretation_planes(v)
    if pooled:
        F = (rotation(v) @ WF.T).T
        fit = (np.abs(l @ F.T) < sin_tol).any(1).sum()
    else:
        fit, F = manhattan(l)
    n, rays, gtr, pr, dep = wall(v)
    ang = np.degrees(np.arccos(np.minimum(1, np.abs(F @ n))))
    Xp = (pr * dep).T
    best = None
    for k, a in enumerate(F):
        off = np.median(Xp @ a)
        dpl = off / (a @ pr)
        res = np.median(np.abs(dep / np.where(dpl > 0, dpl, np.inf) - 1))
        if best is None or res < best[0]: best = (res, k, a, off)
    _, k, a, off = best
    # A segment on the wall lies in it, so it points at the two vanishing directions in the
    # wall's plane, never at the one along its normal: the axis the fewest of the region's
    # segments (midpoint within two cells of it, full-size image) point at.
    g = lambda key: z[f"{v}_{key}"]
    reg, c = g("region"), int(g("cell"))
    big = int(np.argmax(g("sizes"))) + 1
    near = reg == big
    for _ in range(2):
        q = near.copy(); q[1:] |= near[:-1]; q[:-1] |= near[1:]; q[:, 1:] |= near[:, :-1]; q[:, :-1] |= near[:, 1:]; near = q
    scale = z[f"{v}_gt"].shape[1] / 640.0
    mid = ((segs[:, :2] + segs[:, 2:]) / 2 * scale / c).astype(int)
    mid[:, 0] = np.clip(mid[:, 0], 0, near.shape[1] - 1); mid[:, 1] = np.clip(mid[:, 1], 0, near.shape[0] - 1)
    mine = near[mid[:, 1], mid[:, 0]]
    toward = (np.abs(l[mine] @ F.T) < sin_tol)
    counts = toward.sum(0)
    ks = int(np.argmin(counts))
    seg_choice = f"; its {mine.sum()} segments point at the axes {'/'.join(str(x) for x in counts)}, fewest at axis {ks} ({ang[ks]:.1f} deg off)"
    d = off / (a @ rays)
    held.append(np.mean((d > 0) & (np.abs(d - gtr) <= 0.02 * gtr)))
    print(f"view {v}: {len(l)} segments, {fit} fit the frame; its axes are {' / '.join(f'{x:.1f}' for x in ang)} deg from the wall's truth normal; "
          f"the region takes axis {k} ({ang[k]:.1f} deg off) and holds {100*held[-1]:.0f}% within 2%{seg_choice}", flush=True)
print(f"mean {100*np.mean(held):.1f}% (orient.py's modes 31.3%, fit.py's own fit 16.8%, truth's tilt + offset 57%, truth's plane 66.3%, the map 8.5%)")
