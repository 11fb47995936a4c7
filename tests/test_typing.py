"""The package type-checks, and so do README's Python examples; the extension's stub is true to
the compiled module.

mypy runs with the project's configuration (pyproject.toml, [tool.mypy]: strict), through
``mypy.api`` and a cache in the checkout's ``.mypy_cache`` (the one ``python -m mypy`` uses), so
only a first run in a fresh checkout reads the numpy, scipy and pandas stubs. The stub of
``millscope._core`` is compared with the compiled module by mypy's stubtest (every name and
attribute, read-only or not) and by the signature pybind11 writes at the head of each
docstring (parameter names and defaults, which stubtest cannot read from a pybind11 function).
"""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from types import ModuleType

from mypy import api as mypy_api

from millscope import _core

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "pyproject.toml"
STUB = ROOT / "python" / "millscope" / "_core.pyi"
ALLOWLIST = Path(__file__).with_name("core_stubtest_allowlist.txt")

#: names README's examples use that come from the reader's own data
README_PREAMBLE = "import millscope as ms\nlong_record: ms.TorqueRecord\n"


def _mypy(*args: str) -> tuple[str, int]:
    out, err, status = mypy_api.run(["--config-file", str(CONFIG),
                                     "--cache-dir", str(ROOT / ".mypy_cache"), *args])
    return out + err, status


def test_the_package_type_checks() -> None:
    out, status = _mypy(str(ROOT / "python" / "millscope"))
    assert status == 0, out


def readme_python() -> str:
    """README's ```python blocks, in order, as one script."""
    text = (ROOT / "README.md").read_text()
    return "\n".join(re.findall(r"^```python\n(.*?)^```", text, flags=re.M | re.S))


def _mypy_script(code: str, folder: Path) -> tuple[str, int]:
    script = folder / "readme_examples.py"
    script.write_text(README_PREAMBLE + code)
    return _mypy(str(script))


def test_readme_examples_type_check(tmp_path: Path) -> None:
    """As a user's script: every name they use exists with the types they assume (a
    ``LogFit | None`` used as a LogFit, a misspelt attribute, a wrong argument fail here)."""
    code = readme_python()
    assert "ms.analyze_campaign" in code and "ms.Simulation(" in code  # the blocks were found
    out, status = _mypy_script(code, tmp_path)
    assert status == 0, out


def test_the_check_finds_an_error_in_an_example(tmp_path: Path) -> None:
    """The reference works: a fit that may be None, used as a fit, is reported."""
    code = "groups = ms.analyze_campaign([])\nprint(groups[0].fit.equation())\n"
    out, status = _mypy_script(code, tmp_path)
    assert status == 1 and 'Item "None" of "LogFit | None" has no attribute "equation"' in out


def test_the_stub_matches_the_compiled_module(tmp_path: Path) -> None:
    """mypy's stubtest, in a fresh interpreter that imports the extension as the top-level
    module ``_core`` (so that the check reads the stub alone, not the whole package); the
    allowlist names what pybind11 does that a stub should not repeat."""
    assert _core.__file__ is not None
    shutil.copy(_core.__file__, tmp_path / Path(_core.__file__).name)
    shutil.copy(STUB, tmp_path / "_core.pyi")
    env = dict(os.environ, PYTHONPATH=str(tmp_path), MYPYPATH=str(tmp_path))
    run = subprocess.run([sys.executable, "-m", "mypy.stubtest", "_core", "--concise",
                          "--allowlist", str(ALLOWLIST)], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr


def _parameters(function: ast.FunctionDef) -> tuple[list[str], int, list[str]]:
    """Positional parameter names, how many have defaults, keyword-only names."""
    a = function.args
    return [p.arg for p in a.posonlyargs + a.args], len(a.defaults), [p.arg for p in a.kwonlyargs]


def _runtime_signatures(obj: object, name: str) -> list[tuple[list[str], int, list[str]]]:
    """The signatures pybind11 wrote into ``obj``'s docstring (one, or one per overload)."""
    found = []
    for line in (obj.__doc__ or "").splitlines():
        line = re.sub(r"^\d+\. ", "", line)  # an overload's line: "1. name(...) -> ..."
        if line.startswith(name + "("):
            function = ast.parse(f"def {line}: ...").body[0]
            assert isinstance(function, ast.FunctionDef)
            found.append(_parameters(function))
    return found


def _stub_functions(body: list[ast.stmt], owner: ModuleType | type, where: str
                    ) -> list[tuple[str, ast.FunctionDef, object]]:
    """Every function and method of the stub (properties aside) with its runtime object."""
    found = []
    for node in body:
        if isinstance(node, ast.FunctionDef) and not any(
                isinstance(d, ast.Name) and d.id == "property" for d in node.decorator_list):
            found.append((where + node.name, node, getattr(owner, node.name, None)))
        elif isinstance(node, ast.ClassDef) and hasattr(owner, node.name):
            found += _stub_functions(node.body, getattr(owner, node.name),
                                     where + node.name + ".")
    return found


def test_the_stub_signatures_are_those_pybind11_reports() -> None:
    functions = _stub_functions(ast.parse(STUB.read_text()).body, _core, "")
    assert len(functions) > 40 and any(w == "VerletList.spatial_order" for w, _, _ in functions)
    wrong = {where: (_parameters(node), _runtime_signatures(runtime, node.name))
             for where, node, runtime in functions
             if _parameters(node) not in _runtime_signatures(runtime, node.name)}
    assert not wrong, f"stub (names, defaults, keyword-only) vs the module: {wrong}"
