"""Campaign results without DEM runs: synthetic torque records whose noise energy follows a known
law a ln(x) + b (millscope.synthetic), as CaseResults or written into a real campaign store.

The scenes are the paper's cases at scale "tiny" (built, never simulated), so that the cases have
the names, levels, lifters and rotation frequencies the analysis reads.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from concurrent.futures import Future
from typing import Any

import millscope as ms
from millscope.analysis import AnalysisSettings
from millscope.campaign import Case, CaseResult, RunSettings
from millscope.presets import case_key
from millscope.synthetic import SyntheticTorque, synthetic_record

#: The law the tests recover: per unit of level 1, y = -0.45 ln(x) + 1 (b = 1, so that the
#: per-unit fit's a and b are the law's a and b).
LAW = (-0.45, 1.0)
BLOCK = (4.0, 14.0)
SETTINGS = AnalysisSettings(BLOCK)
SCALE = "tiny"


def content_for(scene: ms.Scene, law: tuple[float, float] = LAW, **changes: Any
                ) -> SyntheticTorque:
    """What a synthetic record of this scene holds: its rotation and lifters, the law."""
    lifters = scene.drum.lifters
    assert lifters is not None
    return SyntheticTorque(rotation_hz=scene.rotation_hz, lifters=lifters.count,
                           energy_law=law, **changes)


def record_seed(family: int, level: float, seed: int) -> int:
    """A distinct noise seed per family, level and case seed."""
    return 1_000_003 * family + 1009 * int(level) + seed


def case_results(levels: Iterable[int] = range(1, 8), *, seeds: Sequence[int] = (0,),
                 family: int = 0, particles: str = "ceramic", speed: float = 0.71,
                 law: tuple[float, float] = LAW, settings: AnalysisSettings = SETTINGS,
                 **content: Any) -> list[CaseResult]:
    """Finished, analysed CaseResults of one group, one per level and seed."""
    out = []
    for level in levels:
        scene = ms.presets.pilot_mill(speed, particles, level, scale=SCALE)
        what = content_for(scene, law, **content)
        for seed in seeds:
            record = synthetic_record(level, content=what, seed=record_seed(family, level, seed))
            out.append(CaseResult.from_record(Case(scene, RunSettings(seed=seed)), record,
                                              settings))
    return out


class SyntheticExecutor:
    """An executor for ``Campaign.run`` that answers every case with a synthetic record of its
    scene (level from the case code) instead of simulating it; cases whose scene is named in
    ``fail`` fail. Futures are complete when returned."""

    def __init__(self, law: tuple[float, float] = LAW, fail: Sequence[str] = ()) -> None:
        self.law = law
        self.fail = set(fail)
        self.submitted = 0

    def submit(self, fn: Any, case_dict: dict[str, Any], *_where: Any) -> Future:
        """``fn(case_dict, *_where)`` made up: ``_where`` (where a case saves its progress)
        does not matter to a record that is not simulated."""
        self.submitted += 1
        case = Case.from_dict(case_dict)
        s = case.settings
        future: Future = Future()
        if case.scene.name in self.fail:
            future.set_result({"status": "failed", "hash": case.hash(),
                               "error": "RuntimeError: synthetic failure", "traceback": None,
                               "wall_time_s": 0.0})
            return future
        key = case_key(case.scene)
        level = 1.0 if key.load_level is None else key.load_level
        record = synthetic_record(level, content=content_for(case.scene, self.law),
                                  duration_s=s.duration_s, sample_rate_hz=1.0 / s.sample_dt,
                                  seed=record_seed(0, level, s.seed))
        keep = slice(s.warm_up_samples, None)
        future.set_result({"status": "done", "hash": case.hash(),
                           "time_s": record.time_s[keep], "torque_Nm": record.torque_Nm[keep],
                           "meta": record.meta, "wall_time_s": 0.01, "host": "synthetic",
                           "pid": 0})
        return future


def synthetic_store(store: Any, scenes: Sequence[ms.Scene], *, seeds: Sequence[int] = (0,),
                    fail: Sequence[str] = (), block: tuple[float, float] = BLOCK
                    ) -> list[CaseResult]:
    """Run a campaign of ``scenes`` into ``store`` through :class:`SyntheticExecutor`."""
    camp = ms.Campaign(scenes, store, duration=14.0, block=block, seeds=list(seeds))
    return camp.run(executor=SyntheticExecutor(fail=fail), progress=False)
