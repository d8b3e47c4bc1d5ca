#!/usr/bin/python3
"""cvc_outcomes.py — the CVC insertion's outcome over a grid of needle angles and depths.

    make python-shell ARGS="examples/python/cvc_outcomes.py --angles 30 45 60 --depths 10 20 30 40"

The trainer's table: data/scenes/cvc.yaml (a median adult neck, the ultrasound probe pressing as
scripted), the needle driven from Python through the skin at x = 0 toward the internal jugular
vein at `angle` degrees to the skin, advanced at 10 mm/s to `depth` mm along the needle from the
skin, held, and scored: none (short of the vein), vein (flashback: success), posterior_wall
(through the back wall), artery, or outside_model (the needle went in beyond the modelled neck).
Each cell is one palpate.Simulation stepped with step_many.
Prints the table and writes it as CSV (--csv).
"""
import argparse
import csv
import math
import pathlib
import sys

import numpy as np

import palpate

HERE = pathlib.Path(__file__).resolve().parent
SCENE = HERE.parents[1] / "data" / "scenes" / "cvc.yaml"
VEIN_DEPTH = 0.0179  # m below the skin at x = 0: where cvc.yaml's own insertion aims


def insertion(sim, angle_deg, depth, speed=0.010, above=0.007, hold=0.3):
    """Poses (N, 7) for one insertion: `above` m outside the skin, in to `depth` m, held."""
    a = math.radians(angle_deg)
    direction = np.array([0.0, -math.sin(a), math.cos(a)])
    entry = np.array([0.0, 0.0, -VEIN_DEPTH / math.tan(a)])  # aims at the vein's centre line
    tool_axis = next(t["axis"] for t in sim.tools if t["name"] == "tool")
    q = np.array(palpate.orientation_towards(tool_axis, direction))
    dt = sim.dt
    s = np.concatenate([np.full(int(hold / dt), -above),
                        np.arange(-above, depth, speed * dt),
                        np.full(int(hold / dt), depth)])
    pos = entry + s[:, None] * direction
    return np.hstack([pos, np.tile(q, (len(s), 1))])


def outcome(angle, depth_mm, scene=SCENE):
    sim = palpate.Simulation(scene, record=False)
    forces = sim.step_many(insertion(sim, angle, depth_mm * 1e-3))
    m = sim.metrics()
    return {"angle_deg": angle, "depth_mm": depth_mm, "outcome": m["outcome"],
            "skin_punctures": m["skin_punctures"], "flashback": m["flashback"],
            "deepest_mm": round(m["deepest_depth"] * 1e3, 2),
            "peak_force_N": round(float(np.linalg.norm(forces, axis=1).max()), 3)}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--angles", type=float, nargs="+", default=[30, 45, 60], help="degrees to the skin")
    p.add_argument("--depths", type=float, nargs="+", default=[10, 20, 30, 40], help="mm along the needle")
    p.add_argument("--csv", type=pathlib.Path, help="write the table here")
    a = p.parse_args(argv)
    rows = [outcome(angle, d) for angle in a.angles for d in a.depths]
    width = max(len(r["outcome"]) for r in rows) + 2
    print("angle \\ depth " + "".join(f"{d:>{width}.0f}mm" for d in a.depths))
    for angle in a.angles:
        cells = [r["outcome"] for r in rows if r["angle_deg"] == angle]
        print(f"{angle:>11.0f}°  " + "".join(f"{c:>{width + 2}}" for c in cells))
    if a.csv:
        with a.csv.open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    return rows


if __name__ == "__main__":
    main()
    sys.exit(0)
