"""`mvscope.evaluate` gives the numbers of `mvscope eval`, from a session, an output folder
or arrays."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

import mvscope
from conftest import MIDDLEBURY_ARGS, read_pfm_file, stage_ends


@pytest.fixture(scope="module")
def demo_eval(demo_dir, cli_run, cli):
    out = cli_run(demo_dir, "--method", "acmh", "--seed", 2, "--no-fuse")
    printed = cli("eval", out, "--gt", demo_dir).stdout
    return out, json.loads((out / "eval.json").read_text())["depth"], printed


def test_evaluate_equals_mvscope_eval_for_a_folder_a_session_and_arrays(demo_dir, demo_eval):
    out, expected, printed = demo_eval
    from_folder = mvscope.evaluate(out, gt=demo_dir)
    assert from_folder.to_dict() == expected
    assert str(from_folder) in printed, "the table `mvscope eval` prints"

    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmh", seed=2)
    s.run()
    assert mvscope.evaluate(s, gt=demo_dir).to_dict() == expected
    assert s.evaluate(demo_dir).to_dict() == expected

    arrays = [read_pfm_file(out / "depth" / f"{v:08}.pfm")[..., 0] for v in range(len(s.scene))]
    assert mvscope.evaluate(arrays, gt=demo_dir).to_dict() == expected
    report = mvscope.evaluate({v: a for v, a in enumerate(arrays)}, gt=demo_dir)
    assert report.to_dict() == expected
    assert 0.0 < report.within(0.02) <= 1.0
    assert report.within(0.02) == expected["overall"]["relative"][1][1]
    assert [v.view for v in report.views] == [0, 1, 2] and report.overall.view is None
    # The demo's cameras are exact: no view's median estimate is 5% off its truth's scale.
    assert [v.median_ratio for v in report.views] == [v["median_ratio"] for v in expected["views"]]
    assert all(0.95 < v.median_ratio < 1.05 for v in report.views), report.table
    assert "scale:" not in report.table
    # Each view's scale divided out, as the CLI's eval.json has it, and as scoring the maps
    # divided by their views' median ratios gives. Even with exact cameras a method's
    # estimate has a scale of its own: here 0.993-0.997, which moves the pooled share within
    # 2% from 43.8 to 42.9 (measured).
    assert [v.scale_free["relative"] for v in report.views] == [
        {t: x for t, x in v["scale_free"]["relative"]} for v in expected["views"]
    ]
    scaled = [(a.astype(np.float64) / v.median_ratio).astype(np.float32)
              for a, v in zip(arrays, report.views)]
    again = mvscope.evaluate(scaled, gt=demo_dir)
    assert again.overall.relative == report.overall.scale_free["relative"]
    assert again.overall.relative != report.overall.relative
    assert "median est/gt divided out" in report.table


def test_a_session_splits_its_pixels_by_what_the_sources_see_as_mvscope_eval(demo_dir, demo_eval):
    out, expected, printed = demo_eval
    written = json.loads((out / "eval.json").read_text())["seen"]
    cli_seen = {**written["score"], "per_view": written["per_view"]}
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmh", seed=2)
    s.run()
    report = s.evaluate(demo_dir)
    seen = report.seen
    assert seen is not None and seen["per_view"] == [list(v) for v in cli_seen["per_view"]]
    for k in ("seen", "within_2", "low_texture_within_2", "unseen_within_2"):
        assert seen[k] == pytest.approx(cli_seen[k], abs=1e-12), k
    assert "seen by a source" in printed and "seen by a source" in report.table
    # The same from the run's folder; arrays carry no cameras, so no split.
    from_folder = mvscope.evaluate(out, gt=demo_dir)
    assert from_folder.seen == seen and "seen by a source" in str(from_folder)
    arrays = [read_pfm_file(out / "depth" / f"{v:08}.pfm")[..., 0] for v in range(3)]
    assert mvscope.evaluate(arrays, gt=demo_dir).seen is None
    # The split partitions the pixels: its two shares pool to the overall one.
    assert 0.0 < seen["seen"] < 1.0, "the demo's views frame each other only in part"
    pooled = seen["seen"] * seen["within_2"] + (1 - seen["seen"]) * seen["unseen_within_2"]
    assert pooled == pytest.approx(report.within(0.02), abs=1e-9)
    # Per pixel (Session.seen): each view's share of its truth pixels and the split's
    # scores, recomputed from the masks and the maps.
    masks = s.seen(demo_dir)
    assert len(masks) == 3
    hits = {True: [0, 0], False: [0, 0]}
    for v, mask in enumerate(masks):
        gt = read_pfm_file(demo_dir / "gt" / f"{v:08}.pfm")[..., 0].astype(np.float64)
        assert mask is not None and mask.dtype == bool and mask.shape == gt.shape
        has = np.isfinite(gt) & (gt > 0)
        assert not (mask & ~has).any(), "a pixel without truth is never seen"
        assert mask[has].mean() == pytest.approx(seen["per_view"][v][1], abs=1e-12)
        est = s.maps(v)["depth"].astype(np.float64)
        ok = (est > 0) & (np.abs(est - gt) <= 0.02 * gt)
        for side in (True, False):
            where = has & (mask == side)
            hits[side][0] += int((ok & where).sum())
            hits[side][1] += int(where.sum())
    assert hits[True][0] / hits[True][1] == pytest.approx(seen["within_2"], abs=1e-12)
    assert hits[False][0] / hits[False][1] == pytest.approx(seen["unseen_within_2"], abs=1e-12)


def test_thresholds_are_those_given(demo_dir, demo_eval, cli):
    out, _, _ = demo_eval
    cli("eval", out, "--gt", demo_dir, "--abs", "0.05", "--rel", "0.03,0.1")
    expected = json.loads((out / "eval.json").read_text())["depth"]
    got = mvscope.evaluate(out, gt=demo_dir, abs=[0.05], rel=[0.03, 0.1])
    assert got.to_dict() == expected
    assert list(got.overall.relative) == [0.03, 0.1]


def test_a_middlebury_pair_scored_at_its_size(middlebury, middlebury_session, cli_run, cli):
    out = cli_run(middlebury, *MIDDLEBURY_ARGS)
    cli("eval", out, "--gt", middlebury)
    expected = json.loads((out / "eval.json").read_text())["depth"]
    s = middlebury_session
    report = mvscope.evaluate(s, gt=middlebury)
    assert report.to_dict() == expected
    assert [v.view for v in report.views] == [0], "the pair has ground truth for view 0"
    # At the end of the coarsest scale the maps are smaller; the truth is sampled at their size.
    assert s.num_levels > 1
    s.goto(stage_ends(s.steps)[0])
    try:
        partial = mvscope.evaluate(s, gt=middlebury)
    finally:
        s.run()
    assert 0 < partial.overall.pixels < report.overall.pixels


def test_evaluate_checks_the_arrays(demo_dir):
    with pytest.raises(mvscope.ParameterError):
        mvscope.evaluate([np.zeros((4, 4, 3))], gt=demo_dir)


def _truth_points(scene_dir) -> np.ndarray:
    """Every truth pixel of the scene back-projected with numpy, from the View's K, R, t
    (pixel centres on integers, X_cam = R X_world + t): the package's cameras, not its
    truth cloud."""
    scene = mvscope.Scene.open(scene_dir)
    out = []
    for v, view in enumerate(scene):
        d = mvscope.read_pfm(scene_dir / "gt" / f"{v:08}.pfm")
        ys, xs = np.mgrid[0 : d.shape[0], 0 : d.shape[1]]
        m = d > 0
        ray = np.linalg.inv(view.K) @ np.stack([xs[m], ys[m], np.ones(m.sum())])
        out.append((view.R.T @ (ray * d[m] - view.t[:, None])).T)
    return np.concatenate(out)


def test_evaluate_cloud_equals_mvscope_eval_for_a_folder_a_session_and_a_cloud(demo_dir, cli_run, cli):
    out = cli_run(demo_dir, "--method", "acmh", "--seed", 2)
    printed = cli("eval", out, "--gt", demo_dir).stdout
    saved = json.loads((out / "eval.json").read_text())
    report = mvscope.evaluate_cloud(out, gt=demo_dir)
    assert report.to_dict() == saved["cloud"]
    assert [s.threshold for s in report.scores] == [0.02, 0.05, 0.1]
    assert report.truth_points == saved["cloud_truth"]["points"]
    assert str(report) in printed, "the table `mvscope eval` prints"
    assert 0.0 < report.f1(0.02) < report.f1(0.05) < report.f1(0.1) <= 1.0
    # The same cloud as a PLY file, a Cloud and an array: the run's views are the scene's.
    ply = out / "fused.ply"
    for cloud in (ply, str(ply), mvscope.read_ply(ply), mvscope.read_ply(ply).points):
        assert mvscope.evaluate_cloud(cloud, demo_dir).to_dict() == saved["cloud"]
    # A session fuses the run's cloud (test_cli_equality) and sees the truth through its
    # own cameras.
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmh", seed=2)
    s.run()
    assert mvscope.evaluate_cloud(s, demo_dir).to_dict() == saved["cloud"]


def test_evaluate_cloud_scores_the_truth_perfect_and_a_shifted_truth_low(demo_dir, tmp_path):
    truth = _truth_points(demo_dir)
    exact = mvscope.evaluate_cloud(truth, demo_dir, thresholds=(0.02, 0.05))
    # Every thinned truth point is a pixel's, and every pixel within half a 1 cm cube's
    # diagonal (0.009) of its cube's point.
    assert [(s.accuracy, s.completeness) for s in exact.scores] == [(1.0, 1.0), (1.0, 1.0)]
    assert exact.truth_points < len(truth)
    # 10 cm along the first camera's axis: F1 at 2 cm falls to 0.24 on the 160x120 demo
    # (measured), here below a half.
    shifted = truth + 0.1 * mvscope.Scene.open(demo_dir)[0].R[2]
    assert mvscope.evaluate_cloud(shifted, demo_dir).f1(0.02) < 0.5
    # A ground-truth PLY is the truth as given (`mvscope eval --cloud`).
    mvscope.write_ply(tmp_path / "truth.ply", truth)
    given = mvscope.evaluate_cloud(truth, tmp_path / "truth.ply", thresholds=(0.02,))
    assert given.truth_points == len(truth) and given.f1(0.02) == 1.0


def test_evaluate_cloud_checks_its_input(demo_dir, tmp_path):
    with pytest.raises(mvscope.ParameterError, match="threshold"):
        mvscope.evaluate_cloud(np.zeros((4, 3)), demo_dir, thresholds=(0.02, 0.0))
    with pytest.raises(mvscope.ParameterError, match="N x 3"):
        mvscope.evaluate_cloud(np.zeros((4, 2)), demo_dir)
    bare = tmp_path / "no-truth"
    shutil.copytree(demo_dir, bare, ignore=shutil.ignore_patterns("gt"))
    with pytest.raises(mvscope.EvalError, match="gt/%08d.pfm"):
        mvscope.evaluate_cloud(np.zeros((4, 3)), bare)
    with pytest.raises(mvscope.SceneError, match="does not exist"):
        mvscope.evaluate_cloud(np.zeros((4, 3)), tmp_path / "missing")
    with pytest.raises(mvscope.FileError):
        mvscope.evaluate_cloud(tmp_path / "missing.ply", demo_dir)
