"""The Python package computes what the `mvscope` command line computes: the same maps byte
for byte, at the end of a run and at every stage boundary, stepping forward and back."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

import mvscope
from conftest import (
    DEMO,
    MIDDLEBURY_ARGS,
    MIDDLEBURY_SIZE,
    read_pfm_file,
    read_state_file,
    same_bytes,
    stage_ends,
)


@pytest.fixture(scope="module")
def acmm_session(demo_dir):
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmm", seed=0)
    s.run()
    return s


def assert_maps_equal_run(session, out: pathlib.Path, indices=None):
    for v in range(len(session.scene)):
        index = v if indices is None else indices[v]
        m = session.maps(v)
        depth = read_pfm_file(out / "depth" / f"{index:08}.pfm")[..., 0]
        normal = read_pfm_file(out / "normal" / f"{index:08}.pfm")
        cost = read_pfm_file(out / "cost" / f"{index:08}.pfm")[..., 0]
        assert same_bytes(m["depth"], depth), f"depth of view {v}"
        assert same_bytes(m["normal"], normal), f"normal of view {v}"
        assert same_bytes(m["cost"], cost), f"cost of view {v}"
        assert (m["depth"] > 0).mean() > 0.5, "a run that estimates most pixels"


def test_acmm_depth_maps_equal_mvscope_run_byte_for_byte(acmm_session, demo_dir, cli_run):
    out = cli_run(demo_dir, "--method", "acmm", "--seed", 0, "--no-fuse")
    assert_maps_equal_run(acmm_session, out)


def test_each_method_and_seed_gives_the_clis_maps(demo_dir, cli_run, acmm_session):
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmm", seed=7)
    s.run()
    assert not same_bytes(s.maps(0)["depth"], acmm_session.maps(0)["depth"]), "seeds matter"
    assert_maps_equal_run(s, cli_run(demo_dir, "--seed", 7, "--no-fuse"))
    # The planar prior's path (support points read back, triangulated on the host).
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmp", seed=1)
    s.run()
    assert_maps_equal_run(s, cli_run(demo_dir, "--method", "acmp", "--seed", 1, "--no-fuse"))


def test_a_session_in_batches_gives_the_clis_maps(demo_dir, cli_run, acmm_session):
    # A device budget of 0.8 MiB: the demo's views do not fit at once, so each
    # stage runs them in batches; the maps are the same as held at once, and as the CLI's
    # run in batches.
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmm", seed=0, device_memory=0.8)
    s.run()
    out = cli_run(demo_dir, "--seed", 0, "--no-fuse", "--device-memory", 0.8)
    report = json.loads((out / "report.json").read_text())
    assert report["batches"] >= 2, report["batches"]
    assert_maps_equal_run(s, out)
    for v in range(len(s.scene)):
        assert same_bytes(s.maps(v)["depth"], acmm_session.maps(v)["depth"]), f"view {v}"


def test_a_middlebury_pair_equals_mvscope_run(middlebury, middlebury_session, cli_run):
    s = middlebury_session
    assert max(s.scene[0].width, s.scene[0].height) == MIDDLEBURY_SIZE
    assert s.finished
    assert_maps_equal_run(s, cli_run(middlebury, *MIDDLEBURY_ARGS))


def test_a_subset_of_views_is_numbered_as_the_cli_numbers_it(demo_dir, cli_run):
    scene = mvscope.Scene.open(demo_dir, views=[2, 0])
    assert scene.indices == [2, 0]
    assert [v.scene_index for v in scene.views] == [2, 0]
    s = mvscope.Session(scene, method="acmh")
    s.run()
    out = cli_run(demo_dir, "--method", "acmh", "--views", "2,0", "--no-fuse")
    assert_maps_equal_run(s, out, indices=[2, 0])


def test_fused_cloud_equals_mvscope_runs_ply(acmm_session, demo_dir, cli_run, tmp_path):
    out = cli_run(demo_dir, "--method", "acmm", "--seed", 0)
    cloud = acmm_session.fuse()
    assert len(cloud.points) > 100
    assert cloud.points.shape == cloud.normals.shape == cloud.colors.shape
    cloud.write_ply(tmp_path / "fused.ply")
    assert (tmp_path / "fused.ply").read_bytes() == (out / "fused.ply").read_bytes()
    back = mvscope.read_ply(out / "fused.ply")
    assert same_bytes(back.points, cloud.points)
    assert np.array_equal(back.colors, cloud.colors)


@pytest.fixture(scope="module")
def stage_states(demo_dir, cli, tmp_path_factory):
    """`mvscope plan` (one task per stage) and `mvscope task --stage K` for every stage: the
    CLI's state of every view at the end of each stage."""
    work = tmp_path_factory.mktemp("plan")
    cli("plan", demo_dir, "--out", work, "--seed", 0, "--no-fuse")
    plan = json.loads((work / "plan.json").read_text())
    states = []
    for k in range(len(plan["stages"])):
        cli("task", work, "--stage", k, "--chunk", 0)
        if k + 1 < len(plan["stages"]):
            states.append({v: read_state_file(work / "stages" / f"{k:02}" / f"{v:08}.state")
                           for v in range(DEMO["views"])})
    assert len(states) >= 3, "ACMM has several stages"
    # The last stage's task writes the final maps as `mvscope run` does.
    return states, work


def assert_maps_equal_state(m, state, where):
    h, w = state["height"], state["width"]
    assert (m.level, m.height, m.width) == (state["level"], h, w), where
    assert m["plane"].tobytes() == state["plane"], f"planes {where}"
    assert m["cost"].tobytes() == state["cost"], f"costs {where}"
    aux = np.frombuffer(state["aux"], "<u4").reshape(h, w)
    assert np.array_equal(m["winner"], (aux & 0xFF).astype(np.uint8)), f"winners {where}"


def test_stepping_stage_by_stage_and_back_reaches_the_clis_maps(demo_dir, stage_states):
    stage_states, work = stage_states
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmm", seed=0)
    ends = stage_ends(s.steps)
    assert len(ends) == len(stage_states) + 1
    # Forward, one stage at a time, as the viewer's "stage" button goes.
    for k, end in enumerate(ends[:-1]):
        s.step(unit="stage")
        assert s.cursor == end
        for v in range(len(s.scene)):
            assert_maps_equal_state(s.maps(v), stage_states[k][v], f"stage {k}, view {v}")
    s.step(unit="stage")
    assert s.finished
    assert_maps_equal_run(s, work)
    # Back, a stage at a time, and by going to a step.
    for k in reversed(range(len(ends) - 1)):
        s.back(unit="stage")
        assert s.cursor == ends[k]
        assert_maps_equal_state(s.maps(1), stage_states[k][1], f"back to stage {k}")
    s.goto(ends[2])
    for v in range(len(s.scene)):
        assert_maps_equal_state(s.maps(v), stage_states[2][v], f"goto stage 2, view {v}")


def test_units_half_iteration_view_and_scale_follow_the_schedule(demo_dir):
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmm", seed=0)
    steps = s.steps
    s.step()  # one step
    assert s.cursor == 1 and s.current_step == steps[0]
    s.step(unit="view")  # to the end of view 0's work in the first stage
    assert steps[s.cursor - 1]["view"] == steps[0]["view"]
    assert steps[s.cursor]["view"] != steps[0]["view"]
    s.step(unit="iteration")
    last = steps[s.cursor - 1]
    assert last["action"] in ("half", "init") and (
        last["action"] != "half" or last["half"] == "black"
    )
    s.step(unit="scale")
    assert steps[s.cursor]["level"] == 1 and steps[s.cursor - 1]["level"] == 0
    before = s.maps(0)["depth"].copy()
    s.step(3)
    s.back(3)
    assert same_bytes(s.maps(0)["depth"], before), "three steps forward and back"
    s.back(unit="scale")
    assert s.cursor == 0
    assert s.maps(0) is None, "no maps before the view's first step"


def test_the_demo_scene_is_the_clis(demo_dir, tmp_path):
    scene = mvscope.demo(tmp_path / "demo", **DEMO)
    assert isinstance(scene, mvscope.Scene) and len(scene) == DEMO["views"]
    for f in sorted(p.relative_to(demo_dir) for p in demo_dir.rglob("*") if p.is_file()):
        assert (tmp_path / "demo" / f).read_bytes() == (demo_dir / f).read_bytes(), f
