# test_gil.py — long calls release the GIL: another Python thread makes progress while
# step_many, advance, run and precompute work in C++.
import threading
import time

import numpy as np

import palpate
from conftest import MESHES, SCENES


def progress_during(call):
    """Timestamps a second Python thread took while `call` ran (it ticks every 1 ms)."""
    stamps, stop = [], threading.Event()

    def counter():
        while not stop.is_set():
            stamps.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=counter)
    t.start()
    while not stamps:
        time.sleep(0.001)
    t0 = time.perf_counter()
    call()
    t1 = time.perf_counter()
    stop.set()
    t.join()
    inside = [s for s in stamps if t0 < s < t1]
    return len(inside), t1 - t0


def test_step_many_releases_the_gil():
    sim = palpate.Simulation(SCENES / "default.yaml", record=False)
    n = 60000
    poses = np.column_stack([np.zeros(n), 0.002 * np.sin(np.linspace(0, 60, n)), np.zeros(n)])
    count, seconds = progress_during(lambda: sim.step_many(poses))
    assert seconds > 0.05
    assert count >= max(5, int(0.1 * seconds / 0.0012)), (count, seconds)


def test_advance_releases_the_gil():
    sim = palpate.Simulation(SCENES / "needle-60s.yaml", drive=[], record=False)
    count, seconds = progress_during(lambda: sim.advance(30000))
    assert count >= max(5, int(0.1 * seconds / 0.0012)), (count, seconds)


def test_run_and_precompute_release_the_gil(tmp_path):
    count, seconds = progress_during(lambda: palpate.run(SCENES / "needle-60s.yaml", out=tmp_path, plots=False))
    assert count >= max(5, int(0.1 * seconds / 0.0012)), (count, seconds)
    count, seconds = progress_during(
        lambda: palpate.precompute(MESHES / "liver-smooth.obj", out=tmp_path / "l.predictor", topology="edges"))
    assert count >= int(0.1 * seconds / 0.0012), (count, seconds)


def test_two_threads_stepping_one_simulation_take_turns():
    sim = palpate.Simulation(SCENES / "default.yaml", record=False)
    poses = np.column_stack([np.zeros(2000), np.full(2000, 0.003), np.zeros(2000)])
    threads = [threading.Thread(target=sim.step_many, args=(poses,)) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sim.ticks == 4000
