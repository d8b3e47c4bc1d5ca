#!/usr/bin/python3
"""python_step_many.py — palpate.Simulation.step_many against the same loop in C++.

    PYTHONPATH=build/release/python /usr/bin/python3 bench/python_step_many.py build/release/bench/palpate_bench

Times step_many over 10,000 ticks of default.yaml (a press in and out of the skin, the poses of
BM_StepManyLoopInCpp, bench/bench_python_loop.cpp) and that benchmark, alternately, REPS times
each (adjacent pairs see the same load on a shared machine), and prints both medians and the
median of the pairs' ratios (docs/BENCHMARKS.md, "Python"). Exits 1 when that is over 1.10.
"""
import json
import pathlib
import subprocess
import sys
import time

import numpy as np

import palpate

TICKS = 10000
REPS = 9


def main():
    bench = sys.argv[1]
    limit = float(sys.argv[2]) if len(sys.argv) > 2 else 1.10
    scene = pathlib.Path(__file__).resolve().parents[1] / "data" / "scenes" / "default.yaml"
    t = np.arange(TICKS) * 0.001
    y = 0.003 - 0.004 * 0.5 * (1 - np.cos(2 * np.pi * t / 2.0))
    poses = np.column_stack([np.zeros(TICKS), y, np.zeros(TICKS)])
    sim = palpate.Simulation(scene, record=False)
    sim.step_many(poses)  # warm, as the benchmark's first iteration
    py, cpp = [], []
    for _ in range(REPS):
        t0 = time.perf_counter()
        sim.step_many(poses)
        py.append(time.perf_counter() - t0)
        out = subprocess.run([bench, "--benchmark_filter=BM_StepManyLoopInCpp", "--benchmark_min_time=0.2",
                              "--benchmark_format=json"], capture_output=True, text=True, check=True).stdout
        cpp.append(json.loads(out)["benchmarks"][0]["real_time"] * 1e-3)  # ms -> s, mean over its iterations
    ratio = float(np.median(np.array(py) / np.array(cpp)))
    print(f"step_many {TICKS} ticks: python {np.median(py) * 1e3:.2f} ms, C++ {np.median(cpp) * 1e3:.2f} ms "
          f"(medians of {REPS}); median ratio of adjacent pairs {ratio:.3f}")
    return 0 if ratio <= limit else 1


if __name__ == "__main__":
    sys.exit(main())
