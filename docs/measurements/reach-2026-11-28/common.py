"""What the scripts of this folder share: a room at 320 px, a truth file at the maps' size, and a
session standing at the end of the finest scale's prior stage."""
import pathlib
import warnings

import numpy as np
import mvscope

KITCHEN_A = pathlib.Path("/tmp/s16/k526/rgbd/kitchen-a")  # the colour focal length, 526.5


def open_scene(room):
    warnings.simplefilter("ignore", mvscope.SceneWarning)
    return mvscope.Scene.open(room, max_image_size=320)


def rs(g, shape):
    """`g` at `shape`, nearest pixel (as `mvscope eval`)."""
    rows = np.clip(np.floor((np.arange(shape[0]) + 0.5) * g.shape[0] / shape[0]), 0, g.shape[0] - 1).astype(int)
    cols = np.clip(np.floor((np.arange(shape[1]) + 0.5) * g.shape[1] / shape[1]), 0, g.shape[1] - 1).astype(int)
    return g[np.ix_(rows, cols)]


def at_prior_end(scene, method="regions", params=None):
    """A seed-0 session at the end of the finest scale's prior stage."""
    s = mvscope.Session(scene, method=method, seed=0, params=params or None)
    last = s.num_levels - 1
    s.goto(max(st["index"] for st in s.steps if (st["level"], st["stage"]) == (last, "planar prior")) + 1)
    return s
