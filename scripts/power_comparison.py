"""The power comparison table and figure (docs/power.md) from the runs of power_simulations.py.

For every raw case file: the drive power over the steady part of the run (record time
``STEADY_FROM_S`` s to the end), the charge shape pooled over the snapshots of that part, and
the two models' net power for the same mill, speed, filling and charge density. Writes
``data/power/power_comparison.csv`` (committed) and ``data/power/power_comparison.png``.

Run from the repository root::

    PYTHONPATH=python python scripts/power_comparison.py        # table and figure
    PYTHONPATH=python python scripts/power_comparison.py plot   # figure from the CSV only
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

import millscope as ms
from millscope._files import atomic_write
from millscope.model.charge import charge_shape
from millscope.model.mill_power import (
    critical_speed_rad_s,
    hogg_fuerstenau_power,
    morrell_c_power,
)
from millscope.report.plots import save_figure
from millscope.report.power import plot_power_comparison, read_power_table
from millscope.signal.power import drive_power

OUT = Path("data/power")
RAW = OUT / "raw"
TABLE = OUT / "power_comparison.csv"
FIGURE = OUT / "power_comparison.png"
STEADY_FROM_S = 1.5  # s after the start of rotation: the charge has taken its running shape
BATCHES = 4  # batches of 0.5 s for the standard error of the mean torque
POROSITY = 0.45  # of a bed at rest, balls and particles alike (docs/physics.md, pilot mill)


def filling(scene: ms.Scene) -> float:
    """Fraction of the mill volume the charge takes at rest: the ball bed (porosity 0.45),
    plus the particles' bed where it overflows the balls' voids."""
    by_name = {f.name: f.volume for f in scene.charge}
    balls = by_name["balls"] / (1.0 - POROSITY)
    particles = by_name.get("particles", 0.0) / (1.0 - POROSITY)
    return (balls + max(0.0, particles - POROSITY * balls)) / scene.drum.volume


def row(path: Path) -> dict[str, object]:
    raw = np.load(path)
    particles = str(raw["particles"]) or None
    level = int(raw["load_level"]) or 1
    speed = float(raw["speed_fraction"])
    paper = ms.presets.pilot_mill(speed, particles, level)
    # the ball count of the run (the balls are the largest spheres)
    balls = int(np.count_nonzero(raw["radii_m"] == raw["radii_m"].max()))
    scene = paper.replace(charge=tuple(dataclasses.replace(f, count=balls) if f.name == "balls"
                                       else f for f in paper.charge))
    drum = scene.drum
    rec = ms.TorqueRecord(raw["time_s"], raw["torque_Nm"],
                          {"rotation_hz": float(raw["omega_rad_s"]) / (2 * math.pi)})
    power = drive_power(rec, t_from=STEADY_FROM_S, t_to=float(rec.time_s[-1]) + rec.dt,
                        batches=BATCHES)
    steady = raw["snapshot_time_s"] > STEADY_FROM_S
    shape = charge_shape(raw["positions_m"][steady], raw["radii_m"], raw["masses_kg"],
                         drum.radius)
    j = filling(scene)
    density = shape.mass_kg / (j * drum.volume)
    phi = float(raw["omega_rad_s"]) / critical_speed_rad_s(drum.diameter)
    morrell = morrell_c_power(drum.diameter, drum.length, phi, j, density)
    hf = hogg_fuerstenau_power(drum.diameter, drum.length, phi, j, density,
                               shape.repose_angle_rad)
    ball_filling = filling(scene.replace(charge=scene.charge[:1]))
    group = ("balls" if particles is None else f"LD#{level}") + f", Jb {ball_filling:.2f}"
    out: dict[str, object] = {
        "case": str(raw["scene_name"]), "group": group, "particles": particles or "none",
        "load_level": int(raw["load_level"]), "speed_fraction": speed,
        "speed_fraction_of_sqrt_2g_over_D": round(phi, 5),
        "stiffness_factor": float(raw["stiffness"]), "seed": int(raw["seed"]),
        "dt_s": float(raw["dt_s"]), "cpu_s": round(float(raw["cpu_s"]), 1),
        "steady_from_s": STEADY_FROM_S, "steady_to_s": round(power.span_s[1], 3),
        "balls": balls, "charge_mass_kg": shape.mass_kg, "ball_filling_Jb": ball_filling,
        "filling_J": j, "charge_density_kg_m3": density,
        "mean_torque_Nm": power.mean_torque_Nm, "gravity_torque_Nm": shape.gravity_torque_Nm,
        "power_W": power.power_W, "power_se_W": power.standard_error_W,
        "toe_deg": shape.toe_deg, "shoulder_deg": shape.shoulder_deg,
        "repose_angle_deg": shape.repose_angle_deg,
        "centre_of_mass_x_m": shape.centre_of_mass_m[0],
        "centre_of_mass_y_m": shape.centre_of_mass_m[1],
    }
    for key, model in (("morrell", morrell), ("hogg_fuerstenau", hf)):
        out[f"{key}_power_W"] = model.net_power_W
        out[f"{key}_diff_pct"] = 100.0 * (model.net_power_W - power.power_W) / power.power_W
        out[f"{key}_toe_deg"] = math.degrees(model.toe_rad)
        out[f"{key}_shoulder_deg"] = math.degrees(model.shoulder_rad)
    return out


def main() -> int:
    if sys.argv[1:] != ["plot"]:
        paths = sorted(RAW.glob("*.npz"))
        if not paths:
            print(f"no raw runs in {RAW}: run scripts/power_simulations.py first", file=sys.stderr)
            return 2
        table = pd.DataFrame([row(p) for p in paths])
        table = table.sort_values(["stiffness_factor", "load_level", "balls", "speed_fraction"],
                                  ascending=[False, True, True, True])
        with atomic_write(TABLE) as fh:
            table.to_csv(fh, index=False, float_format="%.6g")
        print(f"wrote {TABLE} ({len(table)} rows)")
    save_figure(plot_power_comparison(read_power_table(TABLE)), FIGURE)
    print(f"wrote {FIGURE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
