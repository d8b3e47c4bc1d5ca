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


def test_ctrl_c_stops_a_run_at_a_tick_and_keeps_what_it_wrote(tmp_path):
    # A realtime run of the default scene (4 s of wall clock); Ctrl-C after 0.4 s, as the main
    # thread gets it (_thread.interrupt_main: SIGINT's own path). The run stops within the force's
    # ramp to zero, the outputs up to the last tick are written and say so, then KeyboardInterrupt.
    import _thread
    import threading
    import time

    timer = threading.Timer(0.4, _thread.interrupt_main)
    t0 = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        palpate.run(SCENES / "default.yaml", out=tmp_path, realtime=True, plots=False)
    elapsed = time.monotonic() - t0
    timer.join()
    scene = palpate.load_scene(SCENES / "default.yaml")
    assert elapsed < scene.duration - 1.0, f"the run went on for {elapsed:.2f} s"
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["interrupted"] is True
    ticks = summary["ticks"]
    assert 0 < ticks < round(scene.duration / scene.dt)
    rows = (tmp_path / "run.csv").read_text().splitlines()
    assert len(rows) == ticks + 1  # the header and every tick run
    # The module is usable again at once: a short headless run completes.
    s = palpate.run(SCENES / "default.yaml", out=tmp_path / "again", plots=False)
    assert s["interrupted"] is False
