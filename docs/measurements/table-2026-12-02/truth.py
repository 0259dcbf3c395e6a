"""What the scripts in this folder share: the truth sampled at an estimate's pixel centres
(as `mvscope eval` resamples it, nearest pixel), and a Regions session at the end of the
finest scale's prior stage."""
import pathlib
import warnings
import numpy as np
import matplotlib; matplotlib.use("Agg")
import matplotlib.pyplot as plt
import mvscope

warnings.simplefilter("ignore", mvscope.SceneWarning)


def resized(a, shape):
    if a.ndim == 3: a = a[..., 0]
    rows = np.clip(np.round((np.arange(shape[0]) + 0.5) * a.shape[0] / shape[0] - 0.5), 0, a.shape[0] - 1)
    cols = np.clip(np.round((np.arange(shape[1]) + 0.5) * a.shape[1] / shape[1] - 0.5), 0, a.shape[1] - 1)
    return a[np.ix_(rows.astype(int), cols.astype(int))]


def truth(scene_dir, name, shape):
    """View `name`'s (e.g. "00000000") truth depth and weak-texture mask at `shape`."""
    d = pathlib.Path(scene_dir)
    gt = resized(np.asarray(mvscope.read_pfm(d / "gt" / f"{name}.pfm")), shape)
    weak = resized(plt.imread(d / "gt" / f"{name}_lowtex.png") > 0, shape)
    return gt, weak


def at_finest_prior(scene_dir, params=None, size=320, seed=0):
    """The scene at `size` and a Regions session standing after its finest prior stage."""
    scene = mvscope.Scene.open(pathlib.Path(scene_dir), max_image_size=size)
    s = mvscope.Session(scene, method="regions", seed=seed, params=params or {})
    last = s.num_levels - 1
    s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
    return scene, s
