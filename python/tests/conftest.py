"""Fixtures: the `mvscope` command line the tests compare against, the small scenes they run
on, and a reader of the files the CLI writes that does not go through the package."""

from __future__ import annotations

import json
import os
import pathlib
import shutil
import subprocess
from typing import Callable, Dict, List, Tuple

import numpy as np
import pytest

import mvscope

REPO = pathlib.Path(__file__).resolve().parents[2]
# The shared test data sits beside the checkout (README: ../shared/data).
DATA = pathlib.Path(os.environ.get("MVSCOPE_DATA", REPO.parent / "shared" / "data"))

# Small enough for lavapipe: a 320x240 ACMM run takes ~30 s there.
DEMO = dict(views=3, width=96, height=72, seed=1)
MIDDLEBURY = DATA / "middlebury2014" / "Teddy"
MIDDLEBURY_SIZE = 120


def _binary() -> str:
    """The CLI built from this tree: $MVSCOPE_BIN, else target/debug/mvscope (what
    `cargo test` builds), built here if missing."""
    env = os.environ.get("MVSCOPE_BIN")
    if env:
        return env
    path = REPO / "target" / "debug" / "mvscope"
    if not path.exists():
        subprocess.run(["cargo", "build", "--bin", "mvscope"], cwd=REPO, check=True)
    return str(path)


@pytest.fixture(scope="session")
def cli() -> Callable[..., subprocess.CompletedProcess]:
    """Runs `mvscope ARGS...`; fails the test on a non-zero exit unless check=False."""
    binary = _binary()

    def run(*args: object, check: bool = True) -> subprocess.CompletedProcess:
        p = subprocess.run(
            [binary, *map(str, args)], capture_output=True, text=True, cwd=REPO
        )
        if check and p.returncode != 0:
            raise AssertionError(
                f"mvscope {' '.join(map(str, args))} failed ({p.returncode}):\n{p.stderr}"
            )
        return p

    return run


@pytest.fixture(scope="session")
def demo_dir(tmp_path_factory, cli) -> pathlib.Path:
    """The demo scene written by the CLI (`mvscope demo`), 96x72, 3 views."""
    out = tmp_path_factory.mktemp("demo") / "scene"
    cli("demo", "--out", out, "--views", DEMO["views"], "--width", DEMO["width"],
        "--height", DEMO["height"], "--seed", DEMO["seed"])
    return out


@pytest.fixture(scope="session")
def cli_run(tmp_path_factory, cli) -> Callable[..., pathlib.Path]:
    """`mvscope run SCENE --out DIR ARGS...` (cached per arguments): the output folder."""
    done: Dict[Tuple[str, ...], pathlib.Path] = {}

    def run(scene: pathlib.Path, *args: object) -> pathlib.Path:
        key = (str(scene), *map(str, args))
        if key not in done:
            out = tmp_path_factory.mktemp("run")
            cli("run", scene, "--out", out, *args)
            done[key] = out
        return done[key]

    return run


@pytest.fixture(scope="session")
def middlebury() -> pathlib.Path:
    if not (MIDDLEBURY / "pair.txt").exists():
        pytest.skip(f"{MIDDLEBURY} is missing (the shared data: ../shared/data)")
    return MIDDLEBURY


def open_downscaled(path: pathlib.Path, size: int) -> "mvscope.Scene":
    """Scene.open with max_image_size, which says so with a SceneWarning (as the CLI prints
    its warnings)."""
    with pytest.warns(mvscope.SceneWarning, match="downscaled"):
        return mvscope.Scene.open(path, max_image_size=size)


@pytest.fixture(scope="session")
def middlebury_session(middlebury):
    """ACMM run to its end on the Middlebury pair at MIDDLEBURY_SIZE, seed 3, τ0 = 0.7 (the
    CLI's counterpart: `--max-image-size 120 --seed 3 --set tau0=0.7`)."""
    s = mvscope.Session(open_downscaled(middlebury, MIDDLEBURY_SIZE), seed=3,
                        params={"tau0": 0.7})
    s.run()
    return s


MIDDLEBURY_ARGS = ("--max-image-size", MIDDLEBURY_SIZE, "--seed", 3, "--set", "tau0=0.7",
                   "--no-fuse")


def read_pfm_file(path: pathlib.Path) -> np.ndarray:
    """A PFM as the file holds it, read here without the package: header "Pf"/"PF", width,
    height, scale (negative: little-endian), one whitespace byte, then float rows BOTTOM to
    TOP (src/io/pfm.rs). Returned top row first, H x W x C, little-endian float32."""
    data = pathlib.Path(path).read_bytes()
    pos, tokens = 0, []
    for _ in range(4):
        while data[pos : pos + 1].isspace():
            pos += 1
        start = pos
        while not data[pos : pos + 1].isspace():
            pos += 1
        tokens.append(data[start:pos])
    pos += 1
    magic, w, h, scale = tokens[0], int(tokens[1]), int(tokens[2]), float(tokens[3])
    c = 3 if magic == b"PF" else 1
    dtype = "<f4" if scale < 0 else ">f4"
    a = np.frombuffer(data[pos:], dtype=dtype, count=w * h * c).reshape(h, w, c)
    return np.ascontiguousarray(a[::-1].astype("<f4"))


def same_bytes(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two float maps hold the same bits (NaN included)."""
    a = np.ascontiguousarray(a, dtype="<f4")
    b = np.ascontiguousarray(b, dtype="<f4")
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def read_state_file(path: pathlib.Path) -> Dict[str, object]:
    """A stage hand-off file of `mvscope task` (src/cluster/unit.rs, src/session/handoff.rs):
    a JSON header line, then "MVSHAND3", level, width, height, flags (u32 LE), then the
    buffers plane, cost, selected, weights, aux, extra (two maps), prior, the restorer's
    aux and the per-region choice's earlier support points (`prior_region_choice`), each
    with a u64 LE length (u64::MAX: absent)."""
    data = pathlib.Path(path).read_bytes()
    header, body = data.split(b"\n", 1)
    assert body[:8] == b"MVSHAND3", path
    level, width, height, flags = np.frombuffer(body[8:24], "<u4")
    pos, buffers = 24, []
    for _ in range(9):
        (n,) = np.frombuffer(body[pos : pos + 8], "<u8")
        pos += 8
        if n == np.iinfo(np.uint64).max:
            buffers.append(None)
            continue
        buffers.append(body[pos : pos + int(n)])
        pos += int(n)
    assert pos == len(body), path
    names = ["plane", "cost", "selected", "weights", "aux", "extra", "prior", "replaced",
             "earlier"]
    out: Dict[str, object] = dict(zip(names, buffers))
    out.update(header=json.loads(header), level=int(level), width=int(width),
               height=int(height))
    return out


def copy_scene(src: pathlib.Path, dst: pathlib.Path) -> pathlib.Path:
    shutil.copytree(src, dst)
    return dst


def stage_ends(steps: List[dict]) -> List[int]:
    """The cursor at the end of each (scale, stage) of a schedule."""
    ends = []
    for i, s in enumerate(steps):
        nxt = steps[i + 1] if i + 1 < len(steps) else None
        if nxt is None or (nxt["level"], nxt["stage"]) != (s["level"], s["stage"]):
            ends.append(i + 1)
    return ends
