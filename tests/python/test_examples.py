# test_examples.py — each example in examples/python runs, at a small size, and says something true.
import importlib.util
import pathlib

import numpy as np
import pytest

from conftest import SOURCE


def example(name):
    spec = importlib.util.spec_from_file_location(name, SOURCE / "examples" / "python" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_fit_charged_material_recovers_the_synthetic_material(tmp_path):
    r = example("fit_charged_material").main(["--ticks", "600", "--samples", "12", "--max-evals", "12",
                                               "--out", str(tmp_path)])
    assert r["png"].stat().st_size > 10_000
    assert r["x"][0] == pytest.approx(1.6, rel=0.15)  # puncture_force, N
    assert r["rms"] < 0.05  # N


def test_sag_falls_as_youngs_modulus_rises(tmp_path):
    r = example("sag_study").main(["--moduli", "5e3", "2e4", "--ticks", "2000", "--out", str(tmp_path)])
    sag = r["sag"]
    assert r["settled"].all() and (sag > 0).all()
    assert r["slope"] == pytest.approx(-1.0, abs=0.15)  # sag ∝ 1/E
    assert r["png"].exists()


def test_cvc_outcome_table(tmp_path):
    csv = tmp_path / "cvc.csv"
    rows = example("cvc_outcomes").main(["--angles", "45", "--depths", "8", "35", "--csv", str(csv)])
    by_depth = {r["depth_mm"]: r for r in rows}
    assert by_depth[8]["outcome"] == "none" and by_depth[8]["skin_punctures"] == 1
    assert by_depth[35]["outcome"] in ("vein", "posterior_wall")
    assert by_depth[35]["deepest_mm"] > by_depth[8]["deepest_mm"]
    assert csv.read_text().startswith("angle_deg,depth_mm,outcome")
