"""Reads dump.py's .npz (with normals). fit.py found kitchen-a's largest flat regions'
support points centred on the truth's plane but unable to give its tilt, and the truth's
normal with the points' median offset holding 57% of the region within 2%. Could the tilt
come from elsewhere in the scene? The reliable pixels' world normals (lowest cost fifth,
two or more sources selected, outside the region) gathered into dominant orientations;
each region then takes the orientation its points fit best, with their median offset."""
import sys
import numpy as np
from wallfit import largest_region

z = np.load(sys.argv[1] if len(sys.argv) > 1 else "/tmp/wall-dump.npz")
nv = int(z["views"])


def canon(n):
    # a normal and its opposite are one orientation
    s = np.sign(n[:, np.argmax(np.abs(n).sum(0))])
    s[s == 0] = 1
    return n * s[:, None]


normals, wall = [], []
for v in range(nv):
    g = lambda k: z[f"{v}_{k}"]
    reg, c, cost, dep = g("region"), int(g("cell")), g("cost"), g("depth")
    big = int(np.argmax(g("sizes"))) + 1
    h, w = dep.shape
    ys, xs = np.mgrid[0:h, 0:w]
    inr = reg[ys // c, xs // c] == big
    ok = (dep > 0) & ~inr & (g("selected_count") >= 2)
    thr = np.percentile(cost[ok], 20)
    sel = ok & (cost <= thr)
    normals.append(g("normal")[sel])
N = canon(np.concatenate(normals))
N /= np.linalg.norm(N, axis=1, keepdims=True)
# greedy modes: the direction with the most normals within 10 degrees, its mean, removed
cos10 = np.cos(np.radians(10))
rng = np.random.default_rng(0)
cand = N[rng.choice(len(N), min(3000, len(N)), replace=False)]
modes, left = [], np.ones(len(N), bool)
for _ in range(6):
    counts = [(np.abs(N[left] @ q) >= cos10).sum() for q in cand]
    q = cand[int(np.argmax(counts))]
    near = left & (np.abs(N @ q) >= cos10)
    m = canon(N[near]).mean(0); m /= np.linalg.norm(m)
    modes.append((m, near.sum() / len(N)))
    left &= ~near
print(f"{len(N)} reliable pixels' normals over {nv} views")


def truth_normal(v):
    r = largest_region(z, v)
    return z[f"{v}_E"][:3, :3].T @ r["normal"], r["mask"], r["rays"], r["gt"]

tn = truth_normal(0)[0]
for k, (m, share) in enumerate(modes):
    print(f"mode {k}: {100*share:.1f}% of them, {np.degrees(np.arccos(min(1, abs(m @ tn)))):.1f} deg from the wall's truth normal")
# A room's surfaces keep to three orthogonal directions (a Manhattan frame): the third
# axis from the two strongest modes, if they are near orthogonal.
m0, m1 = modes[0][0], modes[1][0]
ang01 = np.degrees(np.arccos(min(1, abs(m0 @ m1))))
m2 = np.cross(m0, m1); m2 /= np.linalg.norm(m2)
print(f"modes 0 and 1 are {ang01:.1f} deg apart; their cross product is {np.degrees(np.arccos(min(1, abs(m2 @ tn)))):.1f} deg from the wall's truth normal")
if len(sys.argv) > 2 and sys.argv[2] == "manhattan":
    m1o = m1 - (m1 @ m0) * m0; m1o /= np.linalg.norm(m1o)
    modes = [(m0, 0), (m1o, 0), (m2, 0)]
    print("candidates: the Manhattan frame of modes 0 and 1")
held, chose = [], []
for v in range(nv):
    g = lambda k: z[f"{v}_{k}"]
    reg, c, K, E = g("region"), int(g("cell")), g("K"), g("E")
    R = E[:3, :3]
    big = int(np.argmax(g("sizes"))) + 1
    p, dep = g("points"), g("point_depth")
    pin = (reg[p[:, 1] // c, p[:, 0] // c] == big) & (dep > 0)
    pr = np.linalg.inv(K) @ np.stack([p[pin, 0], p[pin, 1], np.ones(pin.sum())])
    Xp = (pr * dep[pin]).T  # camera frame
    _, inreg, rays, gtr = truth_normal(v)
    best = None
    for k, (m, _) in enumerate(modes):
        nc = R @ m
        off = np.median(Xp @ nc)  # plane nc.X = off
        dpl = off / (nc @ pr)
        res = np.median(np.abs(dep[pin] / np.where(dpl > 0, dpl, np.inf) - 1))
        if best is None or res < best[0]:
            best = (res, k, nc, off)
    _, k, nc, off = best
    d = off / (nc @ rays)
    held.append(np.mean((d > 0) & (np.abs(d - gtr) <= 0.02 * gtr)))
    chose.append(k)
    print(f"view {v}: takes mode {k}; holds its region within 2% on {100*held[-1]:.0f}%")
print(f"mean {100*np.mean(held):.1f}% (fit.py: own fit 16.8%, truth's normal + median offset 57%, the truth's plane 66.3%, the map 8.5%)")
