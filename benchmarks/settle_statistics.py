"""Does the way the charge is prepared change the rotating mill's statistics?

Runs cases from the start (fill, settle, rotation) for several seeds and analyses the block
after the warm-up as a campaign does (``millscope.signal.analysis.analyze_block``: the mean
drive torque, the lifter harmonic's amplitude and the spectral energy after removing the
mean and the LTH). Run it once with each preparation (each millscope on ``PYTHONPATH``, a
``--label`` for each), then compare the labels:

    PYTHONPATH=<old>/python nice -n 5 .venv/bin/python benchmarks/settle_statistics.py \
        --label lattice --scale tiny --seeds 0 1 2 3 4 5
    PYTHONPATH=python nice -n 5 .venv/bin/python benchmarks/settle_statistics.py \
        --label packed --scale tiny --seeds 0 1 2 3 4 5
    .venv/bin/python benchmarks/settle_statistics.py --compare lattice packed

At paper scale, the records of a committed campaign store (made with the earlier placement)
can stand for one label (``--from-store data/study-paper-balls/store``; the block
``--warm-up``..``--duration`` of each).

Per case and label the comparison gives the mean over the seeds with its standard error
(sample standard deviation / sqrt(n)) and the difference of the two means in units of its
standard error (Welch's t). The spectral energy is compared as ln E, whose seed-to-seed
scatter is closer to normal than E's. Rows go to ``benchmarks/results/settle_statistics.csv``,
the comparison to ``benchmarks/results/settle_statistics_compare.csv``.
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"
CASES: dict[str, dict[str, Any]] = {
    "balls": {"particles": None, "load_level": 1},
    "ceramic1": {"particles": "ceramic", "load_level": 1},
    "ceramic4": {"particles": "ceramic", "load_level": 4},
}
QUANTITIES = ("settle_s", "mean_torque_Nm", "lth_amplitude_Nm", "ln_energy")
WINDOW_S = 2.0  # the mean torque is also kept over each window of this length from 0


def _window_means(rec: Any, duration: float, start: float = 0.0) -> dict[str, float]:
    """The mean torque over 0-2 s, 2-4 s, ... of the record (the transient and after); NaN
    for the windows before ``start`` (a record that begins there)."""
    out = {}
    for k in range(int(duration // WINDOW_S)):
        t1, t2 = k * WINDOW_S, (k + 1) * WINDOW_S
        out[f"mean_torque_{t1:g}_{t2:g}s_Nm"] = (rec.block(t1, t2).mean_torque_Nm
                                                 if t1 >= start else float("nan"))
    return out


def run_one(case: str, scale: str, seed: int, duration: float, warm_up: float,
            sampling: str) -> dict[str, Any]:
    import millscope as ms
    from millscope.signal.analysis import analyze_block

    scene = ms.presets.pilot_mill(0.71, scale=scale, **CASES[case])
    sim = ms.Simulation(scene, seed=seed, threads=1, track_energy=False)
    start = time.perf_counter()
    rec = sim.run(duration, sampling=sampling, progress=False)  # type: ignore[arg-type]
    wall = time.perf_counter() - start
    lifters = scene.drum.lifters
    a = analyze_block(rec.block(warm_up, duration + 1e-9),
                      lifters=0 if lifters is None else lifters.count,
                      rotation_hz=scene.rotation_hz)
    assert sim.settle_report is not None
    return {"case": case, "scale": scale, "seed": seed, "sampling": sampling,
            "duration_s": duration, "warm_up_s": warm_up, "settle_s": sim.settle_report.time_s,
            "mean_torque_Nm": a.mean_torque_Nm, "lth_amplitude_Nm": a.lth.amplitude,
            "energy": a.energy.energy, "ln_energy": math.log(a.energy.energy),
            "wall_s": round(wall, 2), "placement": rec.meta.get("filling", "cubic-lattice"),
            "source": "run", **_window_means(rec, duration)}


def from_store(store: Path, case: str, duration: float, warm_up: float,
               sampling: str) -> list[dict[str, Any]]:
    """The same figures for the records of a campaign store (``cases/*.npz``) whose scene is
    ``case`` at paper stiffness with the default time step: the block warm_up..duration of
    each (a store keeps the samples after its warm-up only, so the window means before it
    are NaN)."""
    import millscope as ms
    from millscope.signal.analysis import analyze_block

    want = ms.presets.pilot_mill(0.71, scale="paper", **CASES[case])
    default_dt = ms.Simulation(want, threads=1).dt
    rows = []
    for path in sorted((store / "cases").glob("*.npz")):
        rec = ms.TorqueRecord.load(path)
        settings = rec.meta["campaign"]["case"]["settings"]
        if (ms.Scene.from_dict(rec.meta["scene"]) != want or settings["sampling"] != sampling
                or settings["dt"] != default_dt):
            continue
        lifters = want.drum.lifters
        a = analyze_block(rec.block(warm_up, duration + 1e-9),
                          lifters=0 if lifters is None else lifters.count,
                          rotation_hz=want.rotation_hz)
        rows.append({"case": case, "scale": "paper", "seed": settings["seed"],
                     "sampling": sampling, "duration_s": duration, "warm_up_s": warm_up,
                     "settle_s": rec.meta["settle"]["time_s"],
                     "mean_torque_Nm": a.mean_torque_Nm, "lth_amplitude_Nm": a.lth.amplitude,
                     "energy": a.energy.energy, "ln_energy": math.log(a.energy.energy),
                     "wall_s": rec.meta["campaign"]["wall_time_s"],
                     "placement": rec.meta.get("filling", "cubic-lattice"),
                     "source": path.name,
                     **_window_means(rec, duration, warm_up)})
    return rows


def _read(path: Path) -> list[dict[str, str]]:
    with path.open() as f:
        return list(csv.DictReader(f))


def compare(path: Path, label_a: str, label_b: str) -> list[dict[str, Any]]:
    rows = [r for r in _read(path) if r["label"] in (label_a, label_b)]
    out = []
    keys = sorted({(r["case"], r["scale"], r["sampling"]) for r in rows})
    for case, scale, sampling in keys:
        sel = {lab: [r for r in rows if r["label"] == lab and r["case"] == case
                     and r["scale"] == scale and r["sampling"] == sampling]
               for lab in (label_a, label_b)}
        if not all(len(v) >= 2 for v in sel.values()):
            continue
        windows = [k for k in rows[0] if k.startswith("mean_torque_") and k.endswith("s_Nm")]
        for q in (*QUANTITIES, *windows):
            va, vb = (np.array([float(r[q]) for r in sel[lab]]) for lab in (label_a, label_b))
            sa, sb = (v.std(ddof=1) / math.sqrt(len(v)) for v in (va, vb))
            diff = vb.mean() - va.mean()
            se = math.hypot(sa, sb)
            out.append({"case": case, "scale": scale, "sampling": sampling, "quantity": q,
                        f"{label_a}_n": len(va), f"{label_a}_mean": va.mean(),
                        f"{label_a}_se": sa, f"{label_b}_n": len(vb),
                        f"{label_b}_mean": vb.mean(), f"{label_b}_se": sb,
                        "difference": diff, "difference_se": se,
                        "t": diff / se if se > 0 else float("nan")})
    return out


def _write(path: Path, rows: list[dict[str, Any]], append: bool) -> None:
    if not rows:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    new = not (append and path.exists())
    if not new:
        with path.open() as f:
            header = next(csv.reader(f), [])
        if header != list(rows[0]):
            raise SystemExit(f"{path} has the columns {header}; these rows have "
                             f"{list(rows[0])}: write them to another --out")
    with path.open("a" if append else "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]), lineterminator="\n")
        if new:
            w.writeheader()
        w.writerows(rows)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--label", help="name of the preparation being run")
    p.add_argument("--cases", nargs="+", default=["balls"], choices=sorted(CASES))
    p.add_argument("--scale", default="tiny")
    p.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4, 5])
    p.add_argument("--duration", type=float, default=14.0)
    p.add_argument("--warm-up", type=float, default=4.0)
    p.add_argument("--sampling", default="instant", choices=["instant", "mean"])
    p.add_argument("--compare", nargs=2, metavar=("A", "B"))
    p.add_argument("--from-store", type=Path, metavar="STORE",
                   help="take the rows of --label from the paper-scale records of a store")
    p.add_argument("--out", type=Path, default=RESULTS / "settle_statistics.csv")
    args = p.parse_args()
    if args.compare:
        table = compare(args.out, *args.compare)
        for row in table:
            print(", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                            for k, v in row.items()))
        _write(args.out.with_name(args.out.stem + "_compare.csv"), table, append=False)
        return 0
    if not args.label:
        p.error("--label is needed to run cases")
    if args.from_store:
        for case in args.cases:
            rows = [{"label": args.label, **r} for r in
                    from_store(args.from_store, case, args.duration, args.warm_up,
                               args.sampling)]
            for row in rows:
                print(", ".join(f"{k}={v}" for k, v in row.items()), flush=True)
            _write(args.out, rows, append=True)
        return 0
    for case in args.cases:
        for seed in args.seeds:
            row = {"label": args.label, **run_one(case, args.scale, seed, args.duration,
                                                  args.warm_up, args.sampling)}
            print(", ".join(f"{k}={v}" for k, v in row.items()), flush=True)
            _write(args.out, [row], append=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
