# test_errors.py — a bad scene's palpate.Error carries the command line's text (file, line, key).
import pathlib

import pytest

import palpate
from conftest import SCENES


def bad_scene(tmp_path, old, new):
    text = (SCENES / "default.yaml").read_text()
    assert old in text
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize("old,new,key", [
    ("max_displacement: 0.006", "max_displacement: -0.006", "max_displacement"),
    ("elasticity: 30", "elasticity_typo: 30", "elasticity_typo"),
    ("kind: needle", "kind: scalpel", "kind"),
])
def test_error_text_equals_the_cli(tmp_path, cli, old, new, key):
    path = bad_scene(tmp_path, old, new)
    with pytest.raises(palpate.Error) as e:
        palpate.load_scene(path)
    message = str(e.value)
    assert str(path) in message and key in message
    line = next(i for i, l in enumerate(path.read_text().splitlines(), 1) if new in l)
    assert f"{path}:{line}" in message
    r = cli("run", path, "--out", tmp_path / "out")
    assert r.returncode == 1  # bad input (README, "Exit statuses")
    assert r.stderr == f"palpate run: {message}\n"
    # The same text whichever way Python meets the scene.
    for call in (lambda: palpate.run(path, out=tmp_path / "o2"), lambda: palpate.Simulation(path)):
        with pytest.raises(palpate.Error) as e2:
            call()
        assert str(e2.value) == message


def test_a_missing_file_and_a_missing_mesh(tmp_path, cli):
    with pytest.raises(palpate.Error) as e:
        palpate.load_scene(tmp_path / "none.yaml")
    assert "none.yaml" in str(e.value)
    with pytest.raises(palpate.Error) as e:
        palpate.info(tmp_path / "none.obj")
    r = cli("info", tmp_path / "none.obj")
    assert r.returncode != 0  # CLI11 refuses it before palpate sees it; the Python text names the file
    assert "none.obj" in str(e.value)


def test_palpate_error_is_a_runtime_error():
    assert issubclass(palpate.Error, RuntimeError)


def test_a_scenes_warnings_are_a_list_of_texts():
    # A scripted needle moved sideways to its shaft (docs/scene-format.md, "Warnings").
    scene = palpate.parse_scene(
        "tool: {kind: needle, axis: [0, -1, 0]}\n"
        "device:\n  waypoints:\n    - {t: 0, position: [0, 0.01, 0]}\n    - {t: 1, position: [0.01, 0.004226, 0]}\n"
        "tissues:\n  - name: a\n    patch: {spacing: 0.002}\n",
        name="sideways.yaml")
    assert len(scene.warnings) == 1
    assert scene.warnings[0].startswith("sideways.yaml:5: device.waypoints[1]: the needle moves 11.5 mm at 60°")
    assert palpate.load_scene(SCENES / "cvc.yaml").warnings == []
