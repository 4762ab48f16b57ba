"""The truth the blind benches score on is built apart from the code that builds what they score."""

import ast
from pathlib import Path

import pytest


ROOT = Path(__file__).resolve().parents[1]
# the modules that build truth by plain MJCF edits: dotted name, source
TRUTH_MODULES = {"rmbench.gap.cases.truth": ROOT / "src" / "rmbench" / "gap" / "cases" / "truth.py",
                 "_truth_edits": ROOT / "bench" / "_truth_edits.py",
                 "truth": ROOT / "bench" / "truth" / "__init__.py",
                 "truth.form": ROOT / "bench" / "truth" / "form.py",
                 "truth.robot": ROOT / "bench" / "truth" / "robot.py",
                 "truth.visibility": ROOT / "bench" / "truth" / "visibility.py",
                 "truth.score": ROOT / "bench" / "truth" / "score.py",
                 "truth.structural": ROOT / "bench" / "truth" / "structural.py",
                 "truth.tracker": ROOT / "bench" / "truth" / "tracker.py",
                 "_tracker_truth": ROOT / "bench" / "_tracker_truth.py"}
# what builds a diagnosis's candidates or a calibration's parameters
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


@pytest.mark.parametrize("name", sorted(TRUTH_MODULES), ids=sorted(TRUTH_MODULES))
def test_a_truth_module_imports_nothing_that_builds_candidates_or_parameters(name):
    assert _shared(_imports(TRUTH_MODULES[name], name)) == []


@pytest.mark.parametrize("line", ["from rmbench.robot import variant", "import rmbench.calibrate.design as d",
                                  "from rmbench import gap", "from . import blind", "from ..frf import model",
                                  "def f():\n    from rmbench.robot.parameters import Parameter"],
                         ids=["from-package", "import-as", "from-top", "relative", "relative-up", "lazy"])
def test_the_import_check_sees_every_form_of_import(tmp_path, line):
    path = tmp_path / "m.py"
    path.write_text(line + "\n")
    assert _shared(_imports(path, "rmbench.gap.cases.truth")) != []
