# test_export.py — palpate.run(..., export=...) (docs/export.md): the VTU series read back with
# meshio (Debian's python3-meshio) and checked against the run (tests/export/check_vtu.py), a
# mass-spring organ's tetrahedra as VTK_TETRA cells with its velocities, the glTF's JSON chunk,
# and the refusals.
import json
import struct
import sys
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

import palpate
from conftest import SCENES, SOURCE

sys.path.insert(0, str(SOURCE / "tests" / "export"))
import check_vtu  # noqa: E402


def test_a_needle_run_exports_a_vtu_series_that_meshio_reads_and_matches_the_run(tmp_path):
    s = palpate.run(SCENES / "default.yaml", out=tmp_path, export="vtu", export_every=0.5, plots=False)
    assert s["export_error"] == ""
    times = [e["time"] for e in s["exports"]]
    assert times == pytest.approx([0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0], abs=1e-12)
    root = ET.parse(tmp_path / "run.pvd").getroot()
    sets = list(root.iter("DataSet"))
    assert len(sets) == 9 * 4  # skin, fat, vessel_wall, tools at each time
    assert sorted({float(d.get("timestep")) for d in sets}) == pytest.approx(times)
    assert check_vtu.check(tmp_path, 9) == []
    # The skin is its Bézier surface: triangles; tented 1.48 mm (its particles) at 1 s.
    m = meshio.read(tmp_path / "vtu" / "skin_0002.vtu")
    assert [c.type for c in m.cells] == ["triangle"]
    assert 5e-4 < np.linalg.norm(m.point_data["displacement"], axis=1).max() < 1.5e-3
    assert set(np.unique(m.point_data["role"])) == {1}  # skin


def test_a_mass_spring_organ_exports_tetrahedra_and_velocities(tmp_path):
    s = palpate.run(SCENES / "liver-probe.yaml", out=tmp_path, cache=tmp_path / "cache", export=["vtu", "gltf"],
                    export_every=1.0, plots=False)
    assert s["export_error"] == ""
    times = [e["time"] for e in s["exports"]]
    assert times == pytest.approx([0.0, 1.0, 2.0, 3.0, 4.0, 4.6], abs=1e-12)  # the end is always saved
    assert check_vtu.check(tmp_path, 6) == []
    m = meshio.read(tmp_path / "vtu" / "liver_0003.vtu")  # t = 3 s: pressed, grasped and pulled
    assert [c.type for c in m.cells] == ["tetra"]
    assert len(m.points) == 181 and len(m.cells[0].data) == 596
    assert np.abs(m.point_data["velocity"]).max() > 0
    assert np.linalg.norm(m.point_data["force"], axis=1).max() > 0  # the probe's load on the vertices it holds
    assert set(np.unique(m.point_data["role"])) == {6}  # organ
    # The .glb: its JSON chunk names the liver and the tool, one morph target per state.
    raw = (tmp_path / "run.glb").read_bytes()
    magic, version, _ = struct.unpack_from("<4sII", raw, 0)
    assert magic == b"glTF" and version == 2
    length, kind = struct.unpack_from("<I4s", raw, 12)
    assert kind == b"JSON"
    doc = json.loads(raw[20:20 + length])
    assert [n["name"] for n in doc["nodes"]] == ["liver", "tool"]
    assert len(doc["meshes"][0]["primitives"][0]["targets"]) == 6
    channels = doc["animations"][0]["channels"]
    assert sorted(c["target"]["path"] for c in channels) == ["rotation", "translation", "weights"]


def test_bad_export_values_are_refused(tmp_path):
    with pytest.raises(ValueError, match="export: 'obj'"):
        palpate.run(SCENES / "default.yaml", out=tmp_path, export="obj")
    with pytest.raises(ValueError, match="export_every"):
        palpate.run(SCENES / "default.yaml", out=tmp_path, export="vtu", export_every=0)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    with pytest.raises(palpate.Error, match=str(blocker)):
        palpate.run(SCENES / "default.yaml", out=blocker / "out", export="vtu")
