#!/usr/bin/python3
"""fit_charged_material.py — a charged-particle layer's material fitted to a force–depth curve.

    make python-shell ARGS="examples/python/fit_charged_material.py --out out/fit"

The target is a force–depth curve of a needle pressed slowly into skin (here a synthetic
"measurement": the curve of a known material plus 2 % noise, so the fit can be checked against
the truth; put a measured curve in its place with --target FILE.csv, columns depth_m,force_N).
Each evaluation builds a small flat layer from a dict (palpate.scene_from_dict), presses the
needle to 80 % of max_displacement with step_many and reads the force the device gets;
scipy.optimize.least_squares fits puncture_force and linear_share (the contact law's two free
figures, docs/models/charged-particles.md). Writes fit.png (matplotlib, Agg) and prints the fit.
"""
import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

import palpate  # noqa: E402

MAX_DISPLACEMENT = 0.006  # m, held fixed: the depth at which the layer gives
TRUE = {"puncture_force": 1.6, "linear_share": 0.45}  # the synthetic measurement's material


def layer(puncture_force, linear_share, size=0.02, spacing=0.001):
    return {
        "name": "fit", "duration": 1.0, "dt": 0.001,
        "tool": {"kind": "needle", "radius": 0.0004, "length": 0.08, "axis": [0, -1, 0]},
        "device": {"kind": "scripted", "waypoints": [{"t": 0.0, "position": [0, 0.01, 0]}]},
        "tissues": [{
            "name": "skin", "role": "skin", "model": "charged_particles",
            "patch": {"shape": "flat", "width": size, "height": size, "spacing": spacing,
                      "center": [0, 0, 0], "normal": [0, 1, 0]},
            "material": {"max_displacement": MAX_DISPLACEMENT, "elasticity": 30, "particle_radius": 0.0011,
                         "max_strain": 0.5, "puncture_force": float(puncture_force),
                         "linear_share": float(linear_share)},
        }],
    }


def press(ticks):
    """Tip positions: 150 ticks held above the skin (the force's ramp-in), then down to 80 % of
    max_displacement below the surface's reach (the sphere of influence, 1.5 mm)."""
    reach = 0.0015
    top = np.full(150, reach + 0.001)
    down = np.linspace(reach + 0.001, reach - 0.8 * MAX_DISPLACEMENT, ticks)
    y = np.concatenate([top, down])
    return np.column_stack([np.zeros_like(y), y, np.zeros_like(y)]), 150


def force_depth(params, ticks):
    poses, skip = press(ticks)
    sim = palpate.Simulation(palpate.scene_from_dict(layer(*params)), record=False)
    f = sim.step_many(poses)[skip:, 1]
    depth = 0.0015 - poses[skip:, 1]  # m, the sphere of influence past the rest surface
    return depth, f


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--ticks", type=int, default=1500, help="ticks of the press (slower is more quasi-static)")
    p.add_argument("--samples", type=int, default=25, help="depths compared")
    p.add_argument("--max-evals", type=int, default=60)
    p.add_argument("--target", type=pathlib.Path, help="CSV depth_m,force_N (default: synthetic)")
    p.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/fit"))
    a = p.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)

    if a.target:
        t = np.loadtxt(a.target, delimiter=",", skiprows=1)
        depth, target = t[:, 0], t[:, 1]
    else:
        d, f = force_depth((TRUE["puncture_force"], TRUE["linear_share"]), a.ticks)
        depth = np.linspace(d[0], d[-1], a.samples)[1:]
        rng = np.random.default_rng(1)
        target = np.interp(depth, d, f) * (1 + 0.02 * rng.standard_normal(depth.size))

    def residual(x):
        d, f = force_depth(x, a.ticks)
        return np.interp(depth, d, f) - target

    x0 = np.array([2.5, 0.2])
    fit = least_squares(residual, x0, bounds=([0.1, 0.0], [10.0, 1.0]), diff_step=1e-3,
                        max_nfev=a.max_evals, x_scale=[1.0, 0.1])
    rms = float(np.sqrt(np.mean(fit.fun ** 2)))
    print(f"fit: puncture_force {fit.x[0]:.3f} N, linear_share {fit.x[1]:.3f}; rms {rms * 1e3:.1f} mN "
          f"over {depth.size} depths, {fit.nfev} evaluations"
          + ("" if a.target else f" (truth {TRUE['puncture_force']} N, {TRUE['linear_share']})"))

    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(depth * 1e3, target, "o", ms=4, label="target")
    for x, style, name in ((x0, ":", "start"), (fit.x, "-", "fit")):
        d, f = force_depth(x, a.ticks)
        ax.plot(d * 1e3, f, style, label=f"{name}: F_p {x[0]:.2f} N, share {x[1]:.2f}")
    ax.set_xlabel("depth of the sphere of influence past the skin (mm)")
    ax.set_ylabel("force on the needle (N)")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(a.out / "fit.png", dpi=120)
    return {"x": fit.x, "rms": rms, "nfev": fit.nfev, "png": a.out / "fit.png"}


if __name__ == "__main__":
    main()
