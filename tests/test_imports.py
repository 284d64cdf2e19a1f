"""Imports point one way (STYLE.md): the pipeline, io, robot and report packages never reach into
the commands, the CLI, or each other, apart from the few leaf modules named here."""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "weldseam"
TOP = ("pipeline", "io", "robot", "report", "commands", "cli", "batch", "batch_workers", "synthetic",
       "calibration", "compare")
# What each package may import of weldseam besides itself and the shared types, config, errors and
# geometry. io.atomic (writing a file whole or not at all) serves every writer; a pose file of
# joint angles is read through the arm's kinematics.
ALLOWED = {
    "pipeline": set(),
    "io": {"robot.kinematics"},
    "robot": {"io.atomic"},
    "report": {"io.atomic"},
}


def weldseam_imports(path: Path) -> set[str]:
    """The weldseam modules a file imports anywhere in it (function-level imports included), as
    dotted names below weldseam ("pipeline.run", "io.atomic", ...)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("weldseam."):
            found.add(node.module[len("weldseam."):])
        elif isinstance(node, ast.Import):
            found |= {a.name[len("weldseam."):] for a in node.names if a.name.startswith("weldseam.")}
    return found


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_a_package_imports_no_other_layer_but_what_is_allowed(package):
    wrong = []
    for path in sorted((PACKAGE / package).rglob("*.py")):
        for name in weldseam_imports(path):
            top = name.split(".")[0]
            if top == package or top not in TOP or name in ALLOWED[package]:
                continue
            wrong.append(f"{path.relative_to(PACKAGE)} imports weldseam.{name}")
    assert not wrong, "\n".join(wrong)


def test_the_walk_sees_imports_inside_functions(tmp_path):
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from weldseam.pipeline.run import plan_paths\n    import weldseam.io.atomic\n")
    assert weldseam_imports(module) == {"pipeline.run", "io.atomic"}
