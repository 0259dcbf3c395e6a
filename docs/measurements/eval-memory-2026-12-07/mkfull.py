"""A run folder of full-size "estimates" for measuring `mvscope eval`'s memory.

    python mkfull.py RUN SCENE OUT N

RUN: any `mvscope run` folder of the scene (its params.toml is copied, with the size limit
raised to 2400 px, `views` set to 0..N-1 and `scene` to SCENE). SCENE: a demo scene
(`mvscope demo --views N --width W --height H --out SCENE`). Each view's depth map in
OUT/depth is its truth times (1 + 3% Gaussian noise) times (1 + 1% per view index), with 10%
of the pixels holes: a method's errors in size and spread, seeded, so runs are repeatable.
"""

import os
import re
import sys

import numpy as np

run, scene, out, n = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
os.makedirs(out + "/depth", exist_ok=True)
params = open(run + "/params.toml").read()
params = re.sub(r"(?m)^max_image_size = .*$", "max_image_size = 2400", params)
params = re.sub(r"(?m)^views = .*$", "views = [" + ", ".join(map(str, range(n))) + "]", params)
params = re.sub(r"(?m)^scene = .*$", f'scene = "{scene}"', params)
open(out + "/params.toml", "w").write(params)
rng = np.random.default_rng(0)
for v in range(n):
    raw = open(f"{scene}/gt/{v:08d}.pfm", "rb").read()
    header = raw.split(b"\n", 3)
    w, h = map(int, header[1].split())
    d = np.frombuffer(header[3], dtype="<f4", count=w * h).copy()
    d = d * (1 + 0.03 * rng.standard_normal(d.shape).astype("f4")) * (1 + 0.01 * v)
    d[rng.random(d.shape) < 0.1] = 0
    with open(f"{out}/depth/{v:08d}.pfm", "wb") as f:
        f.write(b"Pf\n%d %d\n-1.0\n" % (w, h))
        f.write(d.astype("<f4").tobytes())
