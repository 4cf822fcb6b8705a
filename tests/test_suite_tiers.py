"""The suite's two tiers: ``python -m pytest -q`` runs the fast one (the tests marked ``slow`` are deselected by
pyproject's addopts), ``python -m pytest -q -m slow`` the slow one; ``.ci/run`` runs the fast one (the README's
command) and not the slow one (a fresh machine compiles every time loop anew: both tiers take longer than CI's 15
minutes), and the developer page says when to run the slow one."""

import ast
import shlex
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SLOW_TIER = ["python", "-m", "pytest", "-q", "-m", "slow"]


def _ini_options() -> dict:
    return tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["pytest"]["ini_options"]


def _mark_expression(args: list[str]) -> str | None:
    """The ``-m`` expression of a command line (the last one wins, as in pytest), or None."""
    found = None
    for i, arg in enumerate(args):
        if arg == "-m" and i + 1 < len(args):
            found = args[i + 1]
        elif arg.startswith("-m") and len(arg) > 2:
            found = arg[2:]
    return found


def _is_slow_mark(node: ast.AST) -> bool:
    """``pytest.mark.slow`` (or a list holding it)."""
    if isinstance(node, (ast.List, ast.Tuple)):
        return any(_is_slow_mark(e) for e in node.elts)
    return (isinstance(node, ast.Attribute) and node.attr == "slow" and isinstance(node.value, ast.Attribute)
            and node.value.attr == "mark")


def _slow_tests() -> list[str]:
    """Every test function marked slow (by its decorators or its module's ``pytestmark``), as file::name."""
    found = []
    for path in sorted((REPO / "tests").rglob("test_*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        module_slow = any(isinstance(s, ast.Assign) and any(getattr(t, "id", None) == "pytestmark" for t in s.targets)
                          and _is_slow_mark(s.value) for s in tree.body)
        for node in tree.body:
            if isinstance(node, ast.FunctionDef) and node.name.startswith("test_"):
                if module_slow or any(_is_slow_mark(d) for d in node.decorator_list):
                    found.append(f"{path.relative_to(REPO)}::{node.name}")
    return found


def test_the_slow_marker_is_registered_and_the_default_run_deselects_it():
    ini = _ini_options()
    assert "slow" in [m.split(":")[0].strip() for m in ini["markers"]]
    assert _mark_expression(shlex.split(ini["addopts"])) == "not slow"
    # a command line -m replaces the addopts one: the slow tier's command selects the slow tests
    assert _mark_expression(shlex.split(ini["addopts"]) + SLOW_TIER[3:]) == "slow"


def test_the_slow_tier_holds_tests_so_its_command_never_collects_nothing():
    slow = _slow_tests()
    assert slow, "no test is marked slow: `python -m pytest -q -m slow` would collect nothing (exit code 5)"
    # and the finder sees both ways of marking (else the count above would say nothing)
    assert "tests/hillsim/test_demo.py::test_every_promised_file_exists" in slow  # the module's pytestmark
    assert "tests/hillsim/test_api.py::test_demo_result_files_have_tidy_floats" in slow  # a decorator
    assert "tests/hillsim/test_api.py::test_import_hillsim_is_light" not in slow


def test_ci_runs_the_readme_command_and_stops_at_a_failure():
    from tests.test_docs import INSTALL_AND_TEST

    lines = (REPO / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    commands = [shlex.split(line, comments=True) for line in lines]
    assert ["set", "-euo", "pipefail"] in commands  # a failing step fails the script
    assert INSTALL_AND_TEST in lines  # exactly the README's second command
    # the slow tier is the developers' check before landing, not CI's (its time on a fresh machine)
    assert SLOW_TIER not in commands and not any("slow" in c for c in commands if "pytest" in c)


def test_the_developer_page_gives_both_commands():
    page = (REPO / "docs" / "developers.md").read_text(encoding="utf-8")
    assert "`python -m pytest -q`" in page and f"`{' '.join(SLOW_TIER)}`" in page
    assert "before a change lands" in page  # when to run the slow tier, now that CI does not
