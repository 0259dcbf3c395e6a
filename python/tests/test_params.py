"""Parameters: the dict of params.toml's names, and a change that re-runs from the first step
it affects (as the viewer does) and changes the maps, to what the CLI computes with them."""

from __future__ import annotations

import pytest

import mvscope
from conftest import read_pfm_file, same_bytes


def test_params_are_params_toml_names_with_their_defaults(demo_dir):
    defaults = mvscope.default_params()
    assert defaults["tau0"] == 0.8 and defaults["lambda"] == 0.2 and defaults["xi"] == 0.1
    assert set(mvscope.SYMBOLS) <= set(defaults), "every documented symbol is a parameter"
    s = mvscope.Session(mvscope.Scene.open(demo_dir), params={"tau0": 0.7, "xi": 0.2}, seed=4)
    p = s.params
    assert (p["tau0"], p["xi"], p["seed"]) == (0.7, 0.2, 4)
    p["tau0"] = 0.1
    assert s.params["tau0"] == 0.7, "params is a copy"


def test_a_methods_own_options_are_defaults_the_caller_overrides(demo_dir):
    # Regions turns its ten options on; the others share the common defaults.
    regions = mvscope.default_params("regions")
    options = ("prior_regions", "prior_flat_points", "prior_confirmed_points", "prior_confidence_score",
               "prior_flat_ramp", "prior_extend", "prior_keep_unseen", "prior_region_cover_seen",
               "prior_region_edge", "prior_flat_noise")
    assert all(regions[o] for o in options)
    assert not any(mvscope.default_params("acmmp")[o] for o in options)
    # and reads a noisy wall's points on both sides of its plane, three tolerances wide
    assert (regions["prior_region_cover_band"], mvscope.default_params("acmmp")["prior_region_cover_band"]) == (3.0, 0.0)
    # and weighs its windows by the adaptive bilateral form
    assert (regions["bilateral_kernel"], mvscope.default_params("acmmp")["bilateral_kernel"]) == (
        "adaptive", "laplacian")
    assert mvscope.check_params({"prior_confidence_score": False}, "regions")["prior_regions"]
    scene = mvscope.Scene.open(demo_dir)
    s = mvscope.Session(scene, method="regions", params={"prior_confidence_score": False})
    assert not s.params["prior_confidence_score"] and s.params["prior_regions"]
    assert mvscope.Session(scene, method="regions").params == regions
    with pytest.raises(mvscope.ParameterError, match="method"):
        mvscope.default_params("acmx")


def test_unknown_or_bad_parameters_raise_parameter_error(demo_dir):
    scene = mvscope.Scene.open(demo_dir)
    with pytest.raises(mvscope.ParameterError, match="unknown parameter"):
        mvscope.Session(scene, params={"tau_0": 0.7})
    with pytest.raises(mvscope.ParameterError, match="tau1"):
        mvscope.Session(scene, params={"tau0": 2.0})
    with pytest.raises(ValueError):  # ParameterError is a ValueError
        mvscope.Session(scene, method="acmx")
    with pytest.raises(mvscope.ParameterError, match="seed"):
        mvscope.Session(scene, seed=1, params={"seed": 2})
    s = mvscope.Session(scene, method="acmh")
    with pytest.raises(mvscope.ParameterError, match="unit"):
        s.step(unit="scales")
    with pytest.raises(mvscope.ParameterError):
        s.set(iterations=0)
    assert s.params["iterations"] == mvscope.default_params()["iterations"]


def test_a_change_reruns_from_the_first_step_it_affects_and_changes_the_maps(
    demo_dir, cli_run
):
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmm", seed=0)
    s.run()
    end = s.cursor
    before = s.maps(0)["depth"].copy()

    # λ is read by the geometric passes only: the re-run starts at the first of them.
    r = s.set(lambda_=0.5)
    first_geometric = next(i for i, st in enumerate(s.steps) if st["stage"].startswith("geometric"))
    assert r == {"from_step": first_geometric, "previous_cursor": end, "cursor": end}
    assert s.cursor == end and s.params["lambda"] == 0.5
    after_lambda = s.maps(0)["depth"].copy()
    assert not same_bytes(after_lambda, before)

    # τ0 is read by every pass: from the start, back to the end; the CLI's maps.
    r = s.set(**{"lambda": 0.2, "tau0": 0.6})
    assert r["from_step"] == 0 and s.cursor == end
    out = cli_run(demo_dir, "--seed", 0, "--set", "tau0=0.6", "--no-fuse")
    for v in range(len(s.scene)):
        depth = read_pfm_file(out / "depth" / f"{v:08}.pfm")[..., 0]
        assert same_bytes(s.maps(v)["depth"], depth), f"view {v} after tau0=0.6"
    assert not same_bytes(s.maps(0)["depth"], before)

    # Back to the defaults: the first maps again, exactly.
    s.set(tau0=0.8)
    assert same_bytes(s.maps(0)["depth"], before)


def test_a_change_mid_run_comes_back_to_the_same_point(demo_dir):
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmh", seed=0)
    s.step(unit="view")
    s.step(2)
    at = s.current_step
    assert (at["view"], at["iteration"], at["half"]) == (1, 1, "red")
    r = s.set(iterations=4)
    assert r["cursor"] != r["previous_cursor"], "view 0 has fewer steps now"
    assert s.current_step["label"] == at["label"], "the same point of the schedule"
