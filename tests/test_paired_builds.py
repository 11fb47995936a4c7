"""benchmarks/paired_builds.py: two builds timed in alternating runs from one checkpoint.

No timing is asserted: only that every run happens, the printed ratios are those of the
printed figures, and bad input is refused before any run.
"""

from __future__ import annotations

import io
import re
import subprocess
import sys
from pathlib import Path

import pytest

import millscope as ms
from millscope import bench

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "paired_builds.py"
BUILD = Path(ms.__file__).resolve().parents[1]  # the folder holding the installed package


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True,
                          cwd=ROOT)


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return bench.tumbling_state("balls", "tiny", 0.05, cache_dir=tmp_path_factory.mktemp("ckpt"),
                                threads=1, progress=False, out=io.StringIO())


@pytest.mark.parametrize("clock", ["wall", "cpu"])
def test_every_pair_is_run_and_its_ratio_is_that_of_its_figures(checkpoint: Path,
                                                                clock: str) -> None:
    out = _run(str(checkpoint), str(BUILD), str(BUILD), "--steps", "50", "--pairs", "3",
               "--clock", clock)
    assert out.returncode == 0, out.stderr
    pairs = re.findall(r"^pair (\d+): A (\S+)  B (\S+)  particle-steps/s  B/A (\S+)$",
                       out.stdout, re.MULTILINE)
    assert [int(p[0]) for p in pairs] == [1, 2, 3]
    for _, a, b, ratio in pairs:
        assert float(a) > 0 and float(b) > 0
        assert float(ratio) == pytest.approx(float(b) / float(a), rel=2e-3)  # 4 digits printed
    median = float(re.search(r"^B/A: median (\S+),", out.stdout, re.MULTILINE).group(1))
    ratios = sorted(float(b) / float(a) for _, a, b, _ in pairs)
    assert median == pytest.approx(ratios[1], rel=2e-3)


@pytest.mark.parametrize(("args", "message"), [
    (["{ckpt}", "/nonexistent", "{build}"], "build folder = '/nonexistent' is not valid"),
    (["/nonexistent.npz", "{build}", "{build}"], "checkpoint = '/nonexistent.npz' is not valid"),
    (["{ckpt}", "{build}", "{build}", "--steps", "1"], "steps = '1' is not valid"),
    (["{ckpt}", "{build}", "{build}", "--pairs", "0"], "pairs = '0' is not valid"),
    (["{ckpt}", "{build}", "{build}", "--threads", "x"], "threads = 'x' is not valid"),
    (["{ckpt}", "{build}", "{build}", "--clock", "sun"],
     "clock = 'sun' is not valid; it must be one of 'wall', 'cpu'"),
])
def test_bad_input_is_refused_with_the_parameter_and_its_range(
        checkpoint: Path, args: list[str], message: str) -> None:
    out = _run(*(a.format(ckpt=checkpoint, build=BUILD) for a in args))
    assert out.returncode == 2
    assert message in out.stderr
    assert "pair 1" not in out.stdout  # nothing ran

