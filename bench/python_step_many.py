#!/usr/bin/python3
"""python_step_many.py — palpate.Simulation.step_many against the same loop in C++.

    PYTHONPATH=build/release/python /usr/bin/python3 bench/python_step_many.py build/release/bench/palpate_bench

Times step_many over 10,000 ticks of default.yaml (a press in and out of the skin, the poses of
BM_StepManyLoopInCpp, bench/bench_python_loop.cpp), median of REPS, then runs that benchmark with
the same repetitions and prints both medians and their ratio (docs/BENCHMARKS.md, "Python").
Exits 1 when the ratio is over 1.10.
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
    times = []
    for _ in range(REPS):
        t0 = time.perf_counter()
        sim.step_many(poses)
        times.append(time.perf_counter() - t0)
    py = float(np.median(times))
    out = subprocess.run([bench, "--benchmark_filter=BM_StepManyLoopInCpp", f"--benchmark_repetitions={REPS}",
                          "--benchmark_format=json"], capture_output=True, text=True, check=True).stdout
    runs = [b for b in json.loads(out)["benchmarks"] if b.get("aggregate_name") == "median"]
    cpp = runs[0]["real_time"] * 1e-3  # ms -> s
    ratio = py / cpp
    print(f"step_many {TICKS} ticks: python {py * 1e3:.2f} ms, C++ {cpp * 1e3:.2f} ms, ratio {ratio:.3f} (median of {REPS})")
    return 0 if ratio <= limit else 1


if __name__ == "__main__":
    sys.exit(main())
