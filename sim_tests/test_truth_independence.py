"""The truth the blind benches score on is built apart from the code that builds what they score."""

import ast
from pathlib import Path

import pytest


ROOT = Path(__file__).resolve().parents[1]


def _truth_modules() -> dict:
    """Every module that builds truth by plain MJCF edits: dotted name, source. Each module of
    ``bench/truth`` (globbed: a new one is checked without being listed) and the library's cases'."""
    found = {"rmbench.gap.cases.truth": ROOT / "src" / "rmbench" / "gap" / "cases" / "truth.py"}
    for path in sorted((ROOT / "bench" / "truth").glob("*.py")):
        found["truth" if path.stem == "__init__" else f"truth.{path.stem}"] = path
    return found


TRUTH_MODULES = _truth_modules()
# what builds a diagnosis's candidates or a calibration's parameters: the variant and parameter
# code, the calibration, the diagnoses and their engines (rmbench.gap.frf, rmbench.gap.tracker.engine)
FORBIDDEN = ("rmbench.robot.variant", "rmbench.robot.parameters", "rmbench.calibrate", "rmbench.gap",
             "rmbench.identify")


def _imports(path: Path, module: str) -> set[str]:
    """Every module (and imported name) a source file of dotted name ``module`` imports, anywhere
    in it, relative imports resolved."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = module.split(".")[:-node.level] if node.level else []
            module_from = ".".join(base + ([node.module] if node.module else []))
            names |= {module_from} | {f"{module_from}.{a.name}" for a in node.names}
    return names


def _shared(imported) -> list[str]:
    return sorted(m for m in imported for f in FORBIDDEN if m == f or m.startswith(f + "."))


def test_every_module_of_the_truth_package_is_checked():
    # the generator's modules, one per concern and data kind: none may slip out of the check
    names = {n for n in TRUTH_MODULES if n.startswith("truth")}
    assert {"truth", "truth.ordinary", "truth.robot", "truth.structural", "truth.visibility", "truth.tracker",
            "truth.control", "truth.form", "truth.score"} <= names


def test_no_truth_module_is_left_beside_the_bench_scripts():
    # the truth lives in bench/truth alone: no legacy generator module beside the scripts
    legacy = sorted(p.name for p in (ROOT / "bench").glob("_*truth*.py"))
    assert legacy == []


@pytest.mark.parametrize("name", sorted(TRUTH_MODULES), ids=sorted(TRUTH_MODULES))
def test_a_truth_module_imports_nothing_that_builds_candidates_or_parameters(name):
    assert _shared(_imports(TRUTH_MODULES[name], name)) == []


@pytest.mark.parametrize("line", ["from rmbench.robot import variant", "import rmbench.calibrate.design as d",
                                  "from rmbench import gap", "from . import blind", "from ..frf import model",
                                  "def f():\n    from rmbench.robot.parameters import Parameter",
                                  "from rmbench.gap.tracker.engine import Engine"],
                         ids=["from-package", "import-as", "from-top", "relative", "relative-up", "lazy", "engine"])
def test_the_import_check_sees_every_form_of_import(tmp_path, line):
    path = tmp_path / "m.py"
    path.write_text(line + "\n")
    assert _shared(_imports(path, "rmbench.gap.cases.truth")) != []
