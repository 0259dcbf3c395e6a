"""The API's shape: scenes and views, the schedule, the maps, the inspector, files."""

from __future__ import annotations

import numpy as np
import pytest

import mvscope
from conftest import DEMO, open_downscaled, read_pfm_file, same_bytes


@pytest.fixture(scope="module")
def scene(demo_dir):
    return mvscope.Scene.open(demo_dir)


def test_device_is_the_clis(cli):
    d = mvscope.device()
    assert d["name"] and isinstance(d["software"], bool)
    assert d["name"] in cli("gpu").stdout


def test_views_carry_cameras_sources_and_ranges(scene, demo_dir):
    assert len(scene) == DEMO["views"] and scene.format == "acmm"
    v = scene.views[0]
    assert (v.width, v.height) == (DEMO["width"], DEMO["height"])
    assert v.K.shape == v.R.shape == (3, 3) and v.t.shape == (3,)
    assert np.allclose(v.R @ v.R.T, np.eye(3), atol=1e-6)
    assert v.K[2, 2] == 1.0 and v.K[0, 0] > 0
    assert v.sources and all(isinstance(s, mvscope.Source) for s in v.sources)
    assert 0 < v.depth_range.min < v.depth_range.max
    assert v.image().shape == (v.height, v.width, 3) and v.image().dtype == np.uint8
    assert v.gray().shape == (v.height, v.width)
    # A point in front of the camera projects with P as X_cam = R X + t says.
    X = v.center + 2.0 * v.R[2]
    x = v.P @ np.append(X, 1.0)
    assert np.allclose(x[:2] / x[2], v.K[:2, 2])
    small = open_downscaled(demo_dir, 48)
    assert max(small[0].width, small[0].height) == 48


def test_steps_are_labelled_like_the_viewers_timeline(scene):
    s = mvscope.Session(scene, method="acmm")
    steps = s.steps
    assert len(s) == len(steps) > 0 and s.cursor == 0 and s.current_step is None
    keys = {"index", "scale", "level", "scales", "stage", "geometric_pass", "view", "action",
            "iteration", "half", "label"}
    assert all(set(st) == keys for st in steps)
    assert steps[0]["label"].startswith("scale 1/3 · photometric · view 0")
    halves = [st for st in steps if st["action"] == "half"]
    assert {st["half"] for st in halves} == {"red", "black"}
    assert {st["scale"] for st in steps} == {1, 2, 3} and s.num_levels == 3
    assert any(st["stage"] == "detail restorer" for st in steps)
    assert mvscope.Session(scene, method="acmh").num_levels == 1


def test_maps_hold_what_the_viewer_shows(scene):
    s = mvscope.Session(scene, method="acmm", seed=0)
    s.step(unit="scale")
    m = s.maps(0)
    assert isinstance(m, mvscope.Maps) and isinstance(m, dict)
    assert (m.level, m.scale) == (0, 1)
    h, w = m.height, m.width
    assert (w, h) < (DEMO["width"], DEMO["height"])
    n = len(scene.views[0].sources)
    assert m["depth"].shape == (h, w) and m["depth"].dtype == np.float32
    assert m["normal"].shape == (h, w, 3) and m["plane"].shape == (h, w, 4)
    assert m["selected"].shape == (h, w, n) and m["selected"].dtype == bool
    assert np.array_equal(m["selected_count"], m["selected"].sum(axis=2))
    assert m["weights"].shape == (h, w, n)
    assert set(np.unique(m["winner"])) <= set(mvscope.WINNERS)
    assert "reprojection_error" in m, "the coarsest scale ends with a geometric pass"
    assert "restorer_difference" not in m
    valid = m["depth"] > 0
    assert np.allclose(np.linalg.norm(m["normal"][valid], axis=1), 1.0, atol=1e-4)
    assert np.array_equal(m["depth"], np.maximum(m["plane"][..., 3], 0))
    # The world normal is the camera normal turned by R^T.
    R = scene.views[0].R
    assert np.allclose(m["normal"][valid], m["normal_camera"][valid] @ R, atol=1e-5)
    # The detail restorer's maps appear at the next scale.
    s.step(unit="stage")
    m2 = s.maps(0)
    assert m2.scale == 2 and m2.width > w
    assert {"restorer_difference", "replaced"} <= set(m2)
    assert m2["replaced"].dtype == bool


def test_winner_colours_are_the_viewers(scene):
    assert set(mvscope.WINNER_COLORS) == set(mvscope.WINNERS)
    colours = list(mvscope.WINNER_COLORS.values())
    assert len(set(colours)) == len(colours), "every code its own colour"
    # The viewer's table (src/viewer/maps.rs WINNER_COLORS): the kept prior plane magenta,
    # a code without an update the invalid grey.
    assert mvscope.WINNER_COLORS[15] == (214, 0, 214)
    assert mvscope.WINNER_COLORS[255] == (31, 31, 31)
    s = mvscope.Session(scene, method="regions", seed=0)
    s.step(unit="scale")
    w = s.maps(0)["winner"]
    rgb = mvscope.winner_rgb(w)
    assert rgb.shape == w.shape + (3,) and rgb.dtype == np.uint8
    codes = np.unique(w)
    assert len(codes) > 3
    for code in codes:
        assert (rgb[w == code] == mvscope.WINNER_COLORS[int(code)]).all(), code
    assert np.array_equal(mvscope.winner_rgb(w.astype(np.int64)), rgb)
    with pytest.raises(ValueError, match="0..255"):
        mvscope.winner_rgb(np.array([[-1, 3]]))


def test_planar_prior_maps(scene):
    s = mvscope.Session(scene, method="acmp", seed=0)
    planar = next(i for i, st in enumerate(s.steps) if st["action"] == "prior plane")
    s.goto(planar + 1)
    m = s.maps(s.steps[planar]["view"])
    assert {"prior_depth", "prior_normal", "support_points", "prior_effect"} <= set(m)
    assert m["support_points"].ndim == 2 and m["support_points"].shape[1] == 2
    assert (m["prior_depth"] > 0).any()


def test_support_cell_explains_the_support_points(scene):
    s = mvscope.Session(scene, method="regions", seed=0)
    steps = s.steps
    support = next(i for i, st in enumerate(steps) if st["action"] == "support points")
    view = steps[support]["view"]
    assert s.support_cell(view, 0, 0) is None, "before the step: nothing to explain"
    planar = next(i for i, st in enumerate(steps) if st["action"] == "prior plane")
    s.goto(planar + 1)
    points = s.maps(view)["support_points"]
    cursor = s.cursor
    chosen = set()
    h, w = s.maps(view).height, s.maps(view).width
    for y in range(0, h, 5):
        for x in range(0, w, 5):
            c = s.support_cell(view, x, y)
            assert c["step"] == support and c["origin"] == (x, y) and c["size"] == 5
            assert len(c["candidates"]) == min(5, w - x) * min(5, h - y)
            if c["chosen"] is not None:
                chosen.add(tuple(c["chosen"]))
                first = c["candidates"][0]
                if not c["by_flat_window"]:
                    # Regions ranks by cost − confidence: the chosen pixel is the best.
                    assert tuple(first["pixel"]) == tuple(c["chosen"])
                    assert first["score"] == pytest.approx(first["cost"] - first["confidence"])
    assert s.cursor == cursor, "the replay comes back to where the session stood"
    # The cells' chosen pixels are the support points the device chose.
    assert chosen == {(int(x), int(y)) for x, y in points}


def test_prior_mesh_is_what_the_prior_was_painted_from(scene):
    s = mvscope.Session(scene, method="regions", seed=0)
    steps = s.steps
    # The finest scale's first triangulation (the coarser ones have too few flat cells).
    tri = next(
        i
        for i, st in enumerate(steps)
        if st["action"] == "triangulate" and st["level"] == s.num_levels - 1
    )
    view = steps[tri]["view"]
    first = next(
        i for i, st in enumerate(steps) if st["action"] == "triangulate" and st["view"] == view
    )
    s.goto(first)
    assert s.prior_mesh(view) is None, "before the view's first triangulation: no mesh"
    planar = next(i for i, st in enumerate(steps) if st["action"] == "prior plane" and i > tri)
    s.goto(planar + 1)
    m, mesh = s.maps(view), s.prior_mesh(view)
    assert (mesh["width"], mesh["height"]) == (m.width, m.height)
    pts = mesh["points"]
    n = len(pts)
    assert n > 0 and mesh["point_depth"].shape == (n,) and mesh["point_normal"].shape == (n, 3)
    # The mesh's points are the support points the maps show.
    assert {tuple(p) for p in pts.tolist()} == {(int(x), int(y)) for x, y in m["support_points"]}
    assert (mesh["point_depth"] > 0).all()
    tris, states = mesh["triangles"], mesh["triangle_state"]
    assert tris.min() >= 0 and tris.max() < n and len(states) == len(tris)
    assert set(states.tolist()) <= set(mvscope.TRIANGLE_STATES) and (states == 0).any()
    r = mesh["regions"]
    c = r["cell"]
    assert r["region"].shape == (-(-m.height // c), -(-m.width // c)) == r["plane"].shape
    planes = r["planes"]
    assert len(planes) > 0 and r["plane"].max() == len(planes) - 1
    for k, p in enumerate(planes):
        # A plane paints cells of its own region, and holds points of that region.
        assert (r["region"][r["plane"] == k] == p["region"] + 1).all()
        inl = pts[p["inliers"]]
        assert (r["region"][inl[:, 1] // c, inl[:, 0] // c] == p["region"] + 1).all()
        assert len(p["inliers"]) <= r["sizes"][p["region"]]
    # Every pixel of a painted cell has its plane's depth along its ray as its prior (or
    # the out-of-range code), as shaders/planar_prior.wgsl `prior_plane` paints it.
    K = scene.views[view].K
    yy, xx = np.mgrid[0 : m.height, 0 : m.width]
    k = r["plane"][yy // c, xx // c]
    painted = k >= 0
    pl = np.array([p["plane"] for p in planes], np.float64)[k[painted]]
    ray = np.stack(
        [(xx - K[0, 2]) / K[0, 0], (yy - K[1, 2]) / K[1, 1], np.ones_like(xx, float)], -1
    )
    den = (pl[:, :3] * ray[painted]).sum(-1)
    d = np.where(den < 0, -pl[:, 3] / np.minimum(den, -1e-12), 0)
    prior = m["prior_depth"][painted]
    inside = prior > 0
    assert inside.mean() > 0.5
    assert np.allclose(prior[inside], d[inside], rtol=1e-4)
    assert (prior[~inside] == -2).all()
    # With the edge rule (`prior_region_edge`, Regions' default) each cell's shade is the
    # median of its pixels' grey (the lower middle value of an even count), as the rule
    # compared them; without it there are none.
    shades = r["shades"]
    g = scene.views[view].gray()
    assert g.shape == (m.height, m.width) and shades.shape == r["region"].shape
    for gy in range(shades.shape[0]):
        for gx in range(shades.shape[1]):
            v = np.sort(g[gy * c : (gy + 1) * c, gx * c : (gx + 1) * c].ravel())
            assert shades[gy, gx] == v[(len(v) - 1) // 2], (gx, gy)
    # Without `prior_region_axes` (Regions' default) every plane is RANSAC's and there is
    # no frame.
    assert all(p["axis"] is None for p in planes) and r["frame"] is None
    e = mvscope.Session(
        scene, method="regions", seed=0,
        params={"prior_region_edge": False},
    )
    e.goto(planar + 1)
    assert e.prior_mesh(view)["regions"]["shades"] is None
    # ACMM builds no planar prior; ACMP no regions.
    assert mvscope.Session(scene, method="acmm", seed=0).prior_mesh(view) is None
    acmp = mvscope.Session(scene, method="acmp", seed=0)
    acmp.goto(next(i for i, st in enumerate(acmp.steps) if st["action"] == "prior plane") + 1)
    assert "regions" not in acmp.prior_mesh(acmp.steps[acmp.cursor - 1]["view"])


def test_prior_mesh_names_each_region_planes_axis(tmp_path, cli):
    """With `prior_region_axes` the mesh carries the view's Manhattan frame (when its
    straight lines give one) and, per region plane, the frame's axis that is its normal.
    On the synthetic room at 240x180 (3 views, seed 1), at the finest scale, view 1's lines
    give a frame (measured: 59 segments, five of its six planes on an axis) and view 0's
    do not (too few segments)."""
    room = tmp_path / "room"
    cli("demo", "--room", "--out", room, "--views", 3, "--width", 240, "--height", 180,
        "--seed", 1)
    s = mvscope.Session(mvscope.Scene.open(room), method="regions", seed=0,
                        params={"prior_region_axes": True})
    steps = s.steps
    finest = [
        i for i, st in enumerate(steps)
        if st["action"] == "prior plane" and st["level"] == s.num_levels - 1
    ]
    # The first prior of views 0 and 1 at the finest scale.
    s.goto(next(i for i in finest if steps[i]["view"] == 1) + 1)
    none = s.prior_mesh(0)["regions"]
    assert none["frame"] is None and all(p["axis"] is None for p in none["planes"])
    r = s.prior_mesh(1)["regions"]
    frame, planes = r["frame"], r["planes"]
    assert frame is not None, "view 1 of the room has a frame (59 segments measured)"
    axes, segs, along = frame["axes"], frame["segments"], frame["along"]
    assert axes.shape == (3, 3) and np.allclose(axes @ axes.T, np.eye(3), atol=1e-6)
    # At least FRAME_MIN_SEGMENTS (40) segments, each inside the image, each pointing at an
    # axis or none (3).
    assert len(segs) >= 40 and segs.shape == (len(segs), 2, 2) and along.shape == (len(segs),)
    assert set(along.tolist()) <= {0, 1, 2, 3} and (along < 3).sum() >= len(segs) // 3
    assert (segs[..., 0] >= -1).all() and (segs[..., 0] <= 241).all()
    assert (segs[..., 1] >= -1).all() and (segs[..., 1] <= 181).all()
    on_axis = [p for p in planes if p["axis"] is not None]
    assert on_axis, [p["axis"] for p in planes]
    for p in on_axis:
        # An axis plane's normal is that axis (up to its sign).
        n = np.asarray(p["plane"][:3], np.float64)
        assert abs(n @ axes[p["axis"]]) > 1 - 1e-5, (p["axis"], n)


def test_prior_mesh_marks_the_regions_that_took_the_later_fit(tmp_path, cli):
    """With `prior_region_choice` each scale's first geometric pass begins with the
    restorer's support points, the mesh triangulates them, and a region whose planes come
    from the fit to that pass's points says so (``later``), its inliers indexing
    ``later_points``. On the synthetic room at 240x180 (3 views, seed 1), at the finest
    scale, some region of some view takes the later fit."""
    room = tmp_path / "room"
    cli("demo", "--room", "--out", room, "--views", 3, "--width", 240, "--height", 180,
        "--seed", 1)
    s = mvscope.Session(mvscope.Scene.open(room), method="regions", seed=0,
                        params={"prior_region_choice": True})
    steps = s.steps
    first = [st for st in steps if st["stage"] == "geometric 1" and st["view"] == 0
             and st["level"] == 0][:3]
    assert [st["action"] for st in first] == ["support points", "triangulate", "init"]
    s.run()
    later = 0
    for view in range(3):
        mesh = s.prior_mesh(view)
        r, pts = mesh["regions"], mesh["points"]
        c, lp = r["cell"], r["later_points"]
        assert lp.shape[1:] == (3,)
        for p in r["planes"]:
            own = lp[p["inliers"], :2].astype(np.int64) if p["later"] else pts[p["inliers"]]
            # Either way, the points a plane holds lie in its region's cells.
            assert (r["region"][own[:, 1] // c, own[:, 0] // c] == p["region"] + 1).all()
            later += p["later"]
    assert later > 0, "no region took the later fit"


def test_anchors_in_the_maps_and_the_inspector(scene):
    s = mvscope.Session(scene, method="acmp", seed=0, params={"prior_anchors": True})
    steps = s.steps
    planar = next(i for i, st in enumerate(steps) if st["action"] == "prior plane")
    view = steps[planar]["view"]
    s.goto(planar)
    assert "anchors" not in s.maps(view), "no codes before the prior planes' step"
    s.goto(planar + 1)
    m = s.maps(view)
    count, radii = m["anchors"], m["anchor_radii"]
    assert count.shape == (m.height, m.width) and radii.shape == (m.height, m.width, 8)
    assert np.array_equal(count, (radii != 0).sum(axis=2))
    anchored = np.argwhere(count > 0)
    assert len(anchored) > 0 and count.max() <= 8
    # An anchored pixel of the first red half: the inspector lists its anchors, one per
    # direction with a radius, and splits each candidate's cost in two.
    first = next(
        i
        for i, st in enumerate(steps)
        if i > planar and st["view"] == view and st.get("half") == "red"
    )
    y, x = next((y, x) for y, x in anchored if (x + y) % 2 == 0)
    s.goto(first + 1)
    info = s.inspect(view, int(x), int(y))
    assert info is not None and info["agrees"]
    a = info["anchors"]
    assert a is not None and len(a["pixels"]) == count[y, x]
    assert a["weight"] == pytest.approx(0.75)
    if sum(info["cpu"]["weights"]) > 0:
        for k, c in enumerate(info["candidates"]):
            if a["own"][k] is not None and a["anchored"][k] is not None:
                m_k = (1 - a["weight"]) * a["own"][k] + a["weight"] * a["anchored"][k]
                assert m_k == pytest.approx(c["cost"], abs=1e-3)
    # A pixel without anchors has none in its inspection.
    y0, x0 = next((y, x) for y, x in np.argwhere(count == 0) if (x + y) % 2 == 0)
    assert s.inspect(view, int(x0), int(y0))["anchors"] is None


def test_the_inspector_explains_a_pixel_with_the_cpu_reference(scene):
    s = mvscope.Session(scene, method="acmm", seed=0)
    s.step(unit="scale")
    before = s.maps(1)
    x, y = 10, 7
    info = s.inspect(1, x, y)
    assert info is not None
    assert info["agrees"], "CPU reference and GPU agree"
    assert (info["x"], info["y"]) == (x, y)
    assert s.steps[info["step"]]["half"] == ("red" if (x + y) % 2 == 0 else "black")
    assert s.steps[info["step"]]["view"] == 1 and s.steps[info["step"]]["level"] == 0
    assert len(info["candidates"]) == 8
    nsrc = len(scene.views[1].sources)
    assert np.asarray(info["cost_matrix"]).shape == (8, nsrc)
    assert len(info["votes"]) == nsrc == len(info["source_views"])
    assert len(info["refinement"]["planes"]) == 6
    assert info["geometric"] and info["reprojection"] is not None
    # The inspected pixel's plane is the one the maps show; the session stands where it did.
    assert np.allclose(info["gpu"]["plane"], before["plane"][y, x])
    assert s.cursor == [st["level"] for st in s.steps].index(1)
    assert same_bytes(s.maps(1)["plane"], before["plane"])
    assert mvscope.Session(scene).inspect(0, 1, 1) is None, "nothing run yet"
    # How the matching cost weighs the pixel's window: ACMM's default is the authors'
    # unsquared weight over an 11 x 11 window sampled every 2nd pixel (36 samples).
    w = info["window"]
    weights = np.asarray(w["weights"], dtype=np.float64)
    assert w["kernel"] == "laplacian" and weights.shape == (11, 11)
    sampled = ~np.isnan(weights)
    assert sampled.sum() == w["samples"] == 36 and np.nanmax(weights) == 1.0
    ws = weights[sampled]
    assert w["effective"] == pytest.approx(ws.sum() ** 2 / (ws**2).sum(), rel=1e-4)
    assert 1.0 <= w["effective"] <= 36.0
    share = np.asarray(w["variance_share"], dtype=np.float64)
    assert np.array_equal(np.isnan(share), ~sampled)
    assert np.nansum(share) == pytest.approx(1.0, abs=1e-5) or np.nansum(share) == 0.0
    # The adaptive weight's σ is the window's spread, never below σc = 3.
    a = mvscope.Session(scene, method="acmm", seed=0, params={"bilateral_kernel": "adaptive"})
    a.step(unit="scale")
    wa = a.inspect(1, x, y)["window"]
    assert wa["kernel"] == "adaptive"
    assert wa["sigma"] == pytest.approx(max(3.0, wa["spread"]), rel=1e-6)


def test_pfm_and_ply_files_round_trip(tmp_path):
    a = np.arange(12, dtype=np.float32).reshape(3, 4)
    mvscope.write_pfm(tmp_path / "a.pfm", a)
    assert same_bytes(read_pfm_file(tmp_path / "a.pfm")[..., 0], a)
    assert same_bytes(mvscope.read_pfm(tmp_path / "a.pfm"), a)
    n = np.random.default_rng(0).normal(size=(5, 3)).astype(np.float32)
    mvscope.write_ply(tmp_path / "c.ply", n, colors=np.full((5, 3), 7, np.uint8))
    c = mvscope.read_ply(tmp_path / "c.ply")
    assert same_bytes(c.points, n) and (c.colors == 7).all() and (c.normals == 0).all()
    # A cloud prints as its size and bounds on one line, not as its arrays.
    lo, hi = n.min(axis=0), n.max(axis=0)
    box = ", ".join(f"{a} {l:.3g}..{h:.3g}" for a, l, h in zip("xyz", lo, hi))
    assert repr(c) == f"Cloud(5 points; {box})"
    assert repr(mvscope.Cloud(*(a[:0] for a in c))) == "Cloud(0 points)"
