# test_commands.py — info, precompute and run as functions: the CLI's options, plain Python
# objects, the same figures as the command line.
import json

import numpy as np
import pytest

import palpate
from conftest import MESHES, SCENES


def cli_fields(stdout):
    return {line[:12].strip(): line[12:].strip() for line in stdout.splitlines()}


@pytest.mark.parametrize("mesh", ["liver.msh", "liver.obj"])
def test_info_equals_the_cli(cli, mesh):
    d = palpate.info(MESHES / mesh)
    r = cli("info", MESHES / mesh)
    assert r.returncode == 0
    f = cli_fields(r.stdout)
    assert d["kind"] == f["kind"]
    assert d["vertices"] == int(f["vertices"]) and d["triangles"] == int(f["triangles"])
    assert [float(v) for v in f["bbox min"].split()] == pytest.approx(d["bbox_min"], rel=1e-5)
    assert d["closed"] == f["closed"].startswith("yes")
    assert isinstance(d["edges"]["median"], float)
    assert palpate.info(MESHES / mesh, scale=2.0)["size"] == pytest.approx(2 * d["size"])


def test_precompute_a_mesh_and_a_scene(tmp_path, cli):
    out = tmp_path / "liver.predictor"
    [w] = palpate.precompute(MESHES / "liver.msh", out=out, stiffness=500, anchors=[3, 39, 64])
    assert w["vertices"] == 181 and w["anchored"] == 3 and w["solver"] == "sparse"
    assert out.stat().st_size == w["bytes"] > 0
    r = cli("precompute", MESHES / "liver.msh", "-o", tmp_path / "cli.predictor", "--stiffness", 500,
            "--anchors", "3,39,64")
    assert r.returncode == 0 and "181 vertices" in r.stdout
    assert (tmp_path / "cli.predictor").stat().st_size == w["bytes"]
    [s] = palpate.precompute(SCENES / "liver-springs.yaml", cache=tmp_path / "cache")
    assert s["tissue"] == "liver" and s["file"].exists()
    with pytest.raises(palpate.Error, match="no mass_spring tissue named 'nope'"):
        palpate.precompute(SCENES / "liver-springs.yaml", tissue="nope", cache=tmp_path / "cache")


def test_run_returns_the_summary_the_cli_writes(tmp_path, cli):
    py = palpate.run(SCENES / "default.yaml", out=tmp_path / "py", plots=False)
    r = cli("run", SCENES / "default.yaml", "--out", tmp_path / "cli")
    assert r.returncode == 0, r.stderr
    written = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert py["ticks"] == 4000 and py["dt"] == 0.001
    assert py["csv"] == tmp_path / "py" / "run.csv" and py["csv"].exists()
    assert py["max_force"] == pytest.approx(written["max_force_N"], rel=1e-9)
    assert py["metrics"]["outcome"] == written["outcome"]
    assert [e["kind"] for e in py["events"]] == [e["kind"] for e in written["events"]]
    assert set(py["stages"]) == {"read_devices", "step_tissues", "render_forces", "watchdog",
                                 "safety_and_write", "record", "live_figures"}


def test_a_headless_simulation_with_the_scenes_devices_equals_run(tmp_path):
    """drive=[] keeps the scene's scripted device: advancing it for the scene's duration is a run."""
    sim = palpate.Simulation(SCENES / "default.yaml", drive=[])
    sim.advance(sim.duration_ticks)
    done = sim.finish()
    py = palpate.run(SCENES / "default.yaml", out=tmp_path, plots=False)
    assert done["metrics"]["peak_force"] == pytest.approx(py["max_force"], rel=0, abs=1e-12)
    assert [e["kind"] for e in done["events"]] == [e["kind"] for e in py["events"]]
    assert np.isfinite(done["series"]["force_N"]).all()
