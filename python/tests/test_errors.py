"""Errors are exceptions of mvscope.errors carrying the CLI's messages."""

from __future__ import annotations

import pytest

import mvscope
from conftest import copy_scene


def cli_error(cli, *args) -> str:
    p = cli(*args, check=False)
    assert p.returncode != 0
    return p.stderr


def test_a_missing_scene_raises_scene_error_naming_the_path(tmp_path, cli):
    missing = tmp_path / "no-such-scene"
    with pytest.raises(mvscope.SceneError) as e:
        mvscope.Scene.open(missing)
    assert str(missing) in str(e.value)
    assert isinstance(e.value, mvscope.Error)
    assert str(e.value) in cli_error(cli, "info", missing), "the CLI's message"


def test_a_broken_camera_file_names_the_file_and_line(demo_dir, tmp_path, cli):
    scene = copy_scene(demo_dir, tmp_path / "broken")
    cam = scene / "cams" / "00000001_cam.txt"
    lines = cam.read_text().splitlines()
    lines[2] = "1.0 not-a-number 0.0 0.0"
    cam.write_text("\n".join(lines) + "\n")
    with pytest.raises(mvscope.SceneError) as e:
        mvscope.Scene.open(scene)
    err = e.value
    assert err.path is not None and err.path.endswith("00000001_cam.txt")
    assert err.line == 3
    assert "00000001_cam.txt:3" in str(err)
    assert str(err) in cli_error(cli, "info", scene)


def test_a_missing_image_names_it(demo_dir, tmp_path):
    scene = copy_scene(demo_dir, tmp_path / "noimage")
    (scene / "images" / "00000002.png").unlink()
    with pytest.raises(mvscope.SceneError, match="00000002"):
        mvscope.Scene.open(scene)


def test_bad_arguments_raise_parameter_errors(demo_dir):
    with pytest.raises(mvscope.ParameterError, match="views"):
        mvscope.Scene.open(demo_dir, views=[0, 7])
    with pytest.raises(mvscope.ParameterError, match="max_image_size"):
        mvscope.Scene.open(demo_dir, max_image_size=0)
    with pytest.raises(mvscope.ParameterError, match="format"):
        mvscope.Scene.open(demo_dir, format="ply")


def test_file_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.pfm"
    bad.write_bytes(b"P6\n1 1\n255\n\0\0\0")
    with pytest.raises(mvscope.FileError) as e:
        mvscope.read_pfm(bad)
    assert e.value.path == str(bad) and str(bad) in str(e.value)
    with pytest.raises(mvscope.FileError):
        mvscope.read_ply(tmp_path / "missing.ply")


def test_session_errors_say_what_to_do(demo_dir):
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmh")
    with pytest.raises(mvscope.SessionError, match="run"):
        s.fuse()
    with pytest.raises(mvscope.ParameterError, match="outside"):
        s.step(unit="view")
        s.inspect(0, 10_000, 3)


def test_evaluate_without_ground_truth_raises_eval_error(demo_dir, tmp_path):
    s = mvscope.Session(mvscope.Scene.open(demo_dir), method="acmh")
    s.run()
    with pytest.raises(mvscope.EvalError, match="gt"):
        mvscope.evaluate(s, gt=tmp_path)
