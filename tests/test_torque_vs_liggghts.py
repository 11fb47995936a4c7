"""benchmarks/torque_vs_liggghts.py: the window means and their block standard errors, and the
reading of LIGGGHTS' torque file (its sign and its window's time stamp), without LIGGGHTS."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def tvl():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        spec = importlib.util.spec_from_file_location("torque_vs_liggghts",
                                                      ROOT / "benchmarks" / "torque_vs_liggghts.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module  # its dataclass looks itself up there
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    yield module
    sys.modules.pop(spec.name, None)


def test_block_mean_skips_and_takes_the_spread_of_block_means(tvl):
    rng = np.random.default_rng(1)
    t = np.arange(200) * 0.01  # 2 s of 10 ms samples
    q = 300.0 + rng.normal(0.0, 20.0, t.size)
    q[t < 0.3] = 1e4  # the skipped start must not count
    got = tvl.block_mean(t, q, 0.3)
    kept = q[30:]
    blocks = kept[:170].reshape(17, 10).mean(axis=1)
    assert got.value == pytest.approx(kept.mean(), rel=1e-12)
    assert got.blocks == 17
    assert got.standard_error == pytest.approx(blocks.std(ddof=1) / math.sqrt(17), rel=1e-12)


def test_block_mean_refuses_a_window_of_one_block(tvl):
    t = np.arange(20) * 0.01
    with pytest.raises(SystemExit, match="fewer than 2 blocks"):
        tvl.block_mean(t, np.ones_like(t), 0.05)


def test_liggghts_torque_is_turned_into_the_drive_torque(tvl, tmp_path):
    """LIGGGHTS writes, at the end of each 4000-step window, the mean torque the particles put
    on the mesh; the drive torque is its negative, stamped at the window's start."""
    window = 4000 * 2.5e-6
    ends = window * np.arange(1, 6)
    rows = [f"{float(e)!r} -1.0 {-(100.0 + k)!r} 0.1 -0.2" for k, e in enumerate(ends)]
    (tmp_path / "torque_state_liggghts.txt").write_text("# time_s torque ...\n" + "\n".join(rows))
    (tmp_path / "liggghts.done").touch()  # the run is there: nothing is launched
    start, drive = tvl.run_liggghts(tmp_path, 0.05, 1)
    np.testing.assert_allclose(start, ends - window, atol=1e-15)
    np.testing.assert_array_equal(drive, 100.0 + np.arange(5))


def test_a_bad_case_is_refused_before_any_work(tvl, tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        tvl.main(["--cases", "8", "--workdir", str(tmp_path)])
    assert exit_info.value.code == 2
    assert "'8' is not valid; each must be balls or a level 1-7" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_each_setting_has_its_own_folder(tvl, tmp_path):
    """Stage outputs are reused only by a call with the same case, seed, spin-up and length."""
    base = tvl.case_folder(tmp_path, "1", 0, 1.0, 1.5)
    others = [tvl.case_folder(tmp_path, "2", 0, 1.0, 1.5),
              tvl.case_folder(tmp_path, "balls", 0, 1.0, 1.5),
              tvl.case_folder(tmp_path, "1", 1, 1.0, 1.5),
              tvl.case_folder(tmp_path, "1", 0, 2.0, 1.5),
              tvl.case_folder(tmp_path, "1", 0, 1.0, 6.0)]
    assert base == tvl.case_folder(tmp_path, "1", 0, 1.0, 1.5)
    assert len({base, *others}) == 6
    assert all(f.parent == tmp_path for f in [base, *others])
