#!/usr/bin/python3
"""sag_study.py — how far a mass-spring organ sags under its own weight, over Young's modulus.

    make python-shell ARGS="examples/python/sag_study.py --out out/sag"

A ball of tissue (radius 3 cm, 1000 kg/m³, 227 masses) resting on its bottom cap, springs from
Young's modulus (material.youngs_modulus), is let settle under gravity for 2 s with the tool far
away; the sag is how far its masses came down on average (m), read from their positions. Linear
elasticity says sag ∝ 1/E: the script prints the table, the slope of log sag over log E (about
−1) over the runs that settled, and plots it (sag.png). A run counts as settled when the organ's
kinetic energy is under 1e-8 J at the end. With this mesh and dt = 1 ms that holds from about
5 kPa to 20 kPa: softer balls are still sinking after 2 s, stiffer ones keep ringing (their
anchors' force stays above the ball's weight) — the table says which.
"""
import argparse
import pathlib
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import palpate  # noqa: E402


def ball(youngs_modulus, radius, spacing, dt):
    """The scene as dicts: one mass-spring sphere patch, the tool 1 m above it."""
    return {
        "name": "sag", "duration": 1.0, "dt": dt,
        "tool": {"kind": "sphere", "radius": 0.005},
        "device": {"kind": "scripted", "waypoints": [{"t": 0.0, "position": [0, 1.0, 0]}]},
        "tissues": [{
            "name": "organ", "model": "mass_spring",
            "patch": {"shape": "sphere", "radius": radius, "spacing": spacing, "center": [0, 0, 0]},
            "material": {"topology": "tet_edges", "solver": "sparse", "youngs_modulus": float(youngs_modulus),
                         "density": 1000.0, "point_damping": 0.5, "spring_damping": 0.0, "gravity": True},
        }],
    }


def sag(youngs_modulus, ticks, radius=0.03, spacing=0.01, dt=0.001, cache=None):
    """(mean sag in m, settled) after `ticks` ticks under gravity alone."""
    sim = palpate.Simulation(ball(youngs_modulus, radius, spacing, dt), cache=cache, record=False)
    organ = sim.tissue("organ")
    rest = organ.rest_positions  # (n, 3) float64: mass-spring positions are views (docs/python.md)
    sim.advance(ticks)  # the tool stays far above
    drop = float(np.mean(rest[:, 1] - organ.positions[:, 1]))
    return drop, organ.figures()["kinetic_energy_J"] < 1e-8


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--moduli", type=float, nargs="+", default=[5e3, 7e3, 1e4, 1.4e4, 2e4], help="Pa")
    p.add_argument("--ticks", type=int, default=2000, help="ticks to settle (dt 1 ms)")
    p.add_argument("--spacing", type=float, default=0.01, help="m, the ball's grid")
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/sag"))
    a = p.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as cache:  # predictors of this study only
        runs = [sag(E, a.ticks, spacing=a.spacing, cache=cache) for E in a.moduli]
    sags = np.array([r[0] for r in runs])
    settled = np.array([r[1] for r in runs])
    print("youngs_modulus_Pa  sag_mm  settled")
    for E, s, ok in zip(a.moduli, sags, settled):
        print(f"{E:>17.0f}  {s * 1e3:6.3f}  {'yes' if ok else 'no'}")
    moduli = np.array(a.moduli)
    fit = settled & (sags > 0)
    slope = float(np.polyfit(np.log(moduli[fit]), np.log(sags[fit]), 1)[0]) if fit.sum() > 1 else float("nan")
    print(f"slope of log sag over log E: {slope:.2f} (linear elasticity: -1)")
    fig, ax = plt.subplots(figsize=(5, 4))
    ax.loglog(a.moduli, sags * 1e3, "o-")
    ax.set_xlabel("Young's modulus (Pa)")
    ax.set_ylabel("sag of the top (mm)")
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(a.out / "sag.png", dpi=120)
    return {"moduli": list(a.moduli), "sag": sags, "settled": settled, "slope": slope, "png": a.out / "sag.png"}


if __name__ == "__main__":
    main()
