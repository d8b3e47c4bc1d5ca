# test_simulation.py — palpate.Simulation from Python: state as read-only numpy views that follow
# the steps and outlive the Python object, step_many equal to single steps, events and outcome,
# the one write path (set_material), a mass-spring organ's state (views of its positions and velocities) and its sag.
import gc

import numpy as np
import pytest

import palpate
from conftest import SCENES


def press(ticks, top=0.002, bottom=-0.005):
    """Needle-tip positions from `top` straight down to `bottom` (m) over `ticks` ticks."""
    y = np.linspace(top, bottom, ticks)
    return np.column_stack([np.zeros(ticks), y, np.zeros(ticks)])


@pytest.fixture
def sim():
    return palpate.Simulation(SCENES / "default.yaml")


def test_views_are_palpates_memory_and_see_each_step(sim):
    skin = sim.tissue("skin")
    assert skin.model == "charged_particles" and skin.layout == "soa"
    x, y, z = skin.positions
    rx, ry, rz = skin.rest_positions
    n = skin.count
    for a in (x, y, z, rx, ry, rz):
        assert a.shape == (n,) and a.dtype == np.float32  # as stored: float, x, y, z apart
    assert skin.flags.shape == (n,) and skin.flags.dtype == np.uint8
    assert skin.force.shape == (3,) and skin.force.dtype == np.float64
    np.testing.assert_array_equal(y, ry)  # at rest before the first tick
    before = y.copy()
    sim.step_many(press(400))
    # The same array object now shows the pressed skin: nothing was re-read or copied.
    assert y.min() < before.min() - 1e-3
    assert np.count_nonzero(y != before) > 0
    assert skin.force[1] > 0.01  # the skin pushes the needle back up (N)
    assert np.shares_memory(y, skin.y)  # a second view is the same memory


def test_writing_through_a_view_is_refused(sim):
    skin = sim.tissue("skin")
    y = skin.y
    with pytest.raises(ValueError, match="read-only"):
        y[0] = 1.0
    with pytest.raises(ValueError):
        y.flags.writeable = True  # palpate's memory cannot be made writeable from Python
    with pytest.raises(ValueError, match="read-only"):
        skin.force[:] = 0
    with pytest.raises(ValueError, match="read-only"):
        skin.rest_positions[0][0] = 1.0


def test_a_view_outlives_its_simulation():
    sim = palpate.Simulation(SCENES / "default.yaml")
    sim.step_many(press(200))
    y = sim.tissue("skin").y
    expected = y.copy()
    del sim
    gc.collect()
    np.testing.assert_array_equal(y, expected)  # still palpate's memory, kept alive by the view


def test_step_many_equals_a_loop_of_single_steps():
    poses = press(600)
    a = palpate.Simulation(SCENES / "default.yaml")
    b = palpate.Simulation(SCENES / "default.yaml")
    many = a.step_many(poses)
    single = np.array([b.step(p) for p in poses])
    assert many.shape == (600, 3) and many.dtype == np.float64
    np.testing.assert_array_equal(many, single)
    assert np.abs(many).max() > 0.5
    np.testing.assert_array_equal(a.tissue("skin").y, b.tissue("skin").y)


def test_step_many_with_orientations_equals_positions_only_at_identity():
    poses = press(200)
    q = np.tile([1.0, 0, 0, 0], (200, 1))
    a = palpate.Simulation(SCENES / "default.yaml").step_many(poses)
    b = palpate.Simulation(SCENES / "default.yaml").step_many(np.hstack([poses, q]))
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError):
        palpate.Simulation(SCENES / "default.yaml").step_many(np.zeros((4, 5)))


def test_a_puncture_is_an_event_and_counts_in_the_metrics():
    sim = palpate.Simulation(SCENES / "default.yaml")
    forces = sim.step_many(press(3000, top=0.01, bottom=-0.02))
    assert sim.ticks == 3000 and sim.time == pytest.approx(3.0)
    m = sim.metrics()
    assert m["skin_punctures"] == 1 and m["passes"] == 1
    stats = sim.stats()
    assert list(stats["stages"]) == ["read_devices", "step_tissues", "render_forces", "watchdog",
                                     "safety_and_write", "record", "live_figures"]
    assert stats["ticks"] == 3000 and stats["step"]["median"] > 0
    assert stats["max_force"] == pytest.approx(np.linalg.norm(forces, axis=1).max())
    done = sim.finish()
    kinds = [(e["kind"], e["tissue"]) for e in done["events"]]
    assert ("puncture", "skin") in kinds
    np.testing.assert_allclose(done["series"]["force_y"], forces[:, 1], rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="finished"):
        sim.step([0, 0, 0])


def test_set_material_is_the_write_path_and_old_views_keep_the_old_build(sim):
    old_y = sim.tissue("skin").y
    sim.step_many(press(300))
    stiff = np.linalg.norm(sim.step([0, -0.005, 0]))
    pressed = old_y.copy()
    sim.set_material("skin", puncture_force=4.0, max_displacement=0.008)
    assert sim.ticks == 0  # rebuilt at rest
    np.testing.assert_array_equal(old_y, pressed)  # the previous build, alive while viewed
    new_y = sim.tissue("skin").y
    assert not np.shares_memory(old_y, new_y)
    sim.step_many(press(300))
    assert np.linalg.norm(sim.step([0, -0.005, 0])) != pytest.approx(stiff)
    with pytest.raises(palpate.Error, match="puncture_force"):
        sim.set_material("skin", puncture_force=-1.0)
    with pytest.raises(palpate.Error, match="no_such_key"):
        sim.set_material("skin", no_such_key=1.0)


def test_a_scene_from_dicts_runs_like_its_file():
    scene = {
        "name": "dict-scene", "duration": 0.5, "dt": 0.001,
        "tool": {"kind": "sphere", "radius": 0.002},
        "device": {"kind": "scripted", "waypoints": [{"t": 0.0, "position": [0, 0.01, 0]}]},
        "tissues": [{
            "name": "pad", "model": "charged_particles",
            "patch": {"shape": "flat", "width": 0.02, "height": 0.02, "spacing": 0.001,
                      "center": [0, 0, 0], "normal": [0, 1, 0]},
            "material": {"max_displacement": 0.005, "elasticity": 20, "particle_radius": 0.001,
                         "puncture_force": 3.0},
        }],
    }
    s = palpate.scene_from_dict(scene)
    assert s.name == "dict-scene" and s.tissues == ["pad"]
    sim = palpate.Simulation(scene)  # a dict is accepted where a scene is
    f = sim.step_many(press(300, top=0.004, bottom=-0.002))
    assert f[-1, 1] > 0
    scene["tissues"][0]["material"]["elasticity"] = -3
    with pytest.raises(palpate.Error) as e:
        palpate.scene_from_dict(scene, name="my.yaml")
    line = palpate.scene_yaml(scene).splitlines().index("      elasticity: -3") + 1
    assert str(e.value).startswith(f"my.yaml:{line}:") and "elasticity" in str(e.value)


def test_a_mass_spring_organ_sags_and_its_state_is_a_view_that_sees_each_step(tmp_path):
    sim = palpate.Simulation(SCENES / "liver-springs.yaml", cache=tmp_path)
    liver = sim.tissue("liver")
    assert liver.model == "mass_spring" and liver.layout == "aos"
    assert liver.x is None
    rest = liver.rest_positions
    assert rest.shape == (181, 3) and rest.dtype == np.float64 and not rest.flags.writeable
    pos, vel = liver.positions, liver.velocities
    for a in (pos, vel):  # views of SpringState::x and v: (n, 3) float64, read-only
        assert a.shape == (181, 3) and a.dtype == np.float64 and not a.flags.writeable
        assert a.flags.c_contiguous
        with pytest.raises(ValueError):
            a[0, 0] = 1.0
    np.testing.assert_array_equal(pos, rest)  # at rest before the first tick
    assert not vel.any()
    far = [-0.41, 8.0, 0.66]  # the sphere well above the organ: gravity alone
    for _ in range(10):
        sim.step(far)
    # The same array objects, taken before the steps, show the state after them.
    assert pos[:, 1].mean() < rest[:, 1].mean()  # sagged under gravity (y up)
    assert vel[:, 1].mean() < 0  # still falling
    now = liver.positions
    assert now.shape == (181, 3) and np.shares_memory(now, pos)
    snap = liver.snapshot()["points"]  # the drawn copy (float32) agrees with the view
    np.testing.assert_allclose(snap, pos, atol=1e-6)
    assert liver.figures()["kinetic_energy_J"] > 0
    del sim
    gc.collect()
    assert np.isfinite(pos).all()  # the view keeps the simulation's memory alive
