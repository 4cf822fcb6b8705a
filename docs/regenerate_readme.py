"""Regenerate the README's figures and generated text blocks from the code, so they cannot go stale silently.

    PYTHONPATH=. python docs/regenerate_readme.py            # run the demo, rewrite docs/*.png and the README blocks
    PYTHONPATH=. python docs/regenerate_readme.py --check    # exit 1 when a README block differs from the code's output

Figures: ``docs/extended.png``, ``docs/hillchart.png``, ``docs/load_rejection.png`` and ``docs/step_response.png``
are copied from a ``hillsim demo --fast`` run (matplotlib output; ``--check`` compares text only, since PNG bytes
depend on the matplotlib and font versions).

Text blocks: every README region between ``<!-- generated: NAME -->`` and ``<!-- end generated -->`` is replaced by
:func:`blocks`'s text for NAME (the demo's terminal summary, the ``hillsim linearize`` example's real output).
``tests/hillsim/test_readme.py`` runs the same comparison on the shared demo run.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import re
import shutil
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
#: docs/ figure -> the demo file it is copied from.
FIGURES = {
    "extended.png": "extended.png",
    "hillchart.png": "hillchart.png",
    "load_rejection.png": "load_rejection/transient.png",
    "step_response.png": "identification/step_response.png",
}
LINEARIZE_ARGS = ["linearize", "data_synthetic/francis/nets.json", "--n11", "67.8", "--opening", "23.46"]
BLOCK = re.compile(r"(<!-- generated: (?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- end generated -->)", re.S)


def _fenced(text: str) -> str:
    return "```\n" + text.rstrip("\n") + "\n```\n"


def linearize_example() -> str:
    """The README's ``hillsim linearize`` example with its real output."""
    from hillsim.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.chdir(REPO):
        code = main(LINEARIZE_ARGS + ["--quiet"])
    if code != 0:
        raise RuntimeError(f"hillsim {' '.join(LINEARIZE_ARGS)} exited {code}")
    return _fenced("$ hillsim " + " ".join(LINEARIZE_ARGS) + "\n" + out.getvalue())


def demo_summary(demo_dir: Path) -> str:
    """The demo's terminal summary, from its ``demo_summary.json``."""
    from hillsim.demo import format_summary

    summary = json.loads((Path(demo_dir) / "demo_summary.json").read_text(encoding="utf-8"))
    return _fenced(format_summary(summary))


def blocks(demo_dir: Path) -> dict[str, str]:
    """Generated README text by block name."""
    return {"demo-summary": demo_summary(demo_dir), "linearize-example": linearize_example()}


def stale_blocks(readme_text: str, expected: dict[str, str]) -> list[str]:
    """Names of the README blocks whose text differs from ``expected`` (or that the README lacks)."""
    found = {m["name"]: m["body"] for m in BLOCK.finditer(readme_text)}
    return sorted(name for name, text in expected.items() if found.get(name) != text)


def rewrite(readme_text: str, expected: dict[str, str]) -> str:
    return BLOCK.sub(lambda m: m.group(1) + expected.get(m["name"], m["body"]) + m.group(4), readme_text)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare only; exit 1 when the README is stale")
    parser.add_argument("--demo-dir", type=Path, default=None, help="reuse this demo output instead of running it")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        demo_dir = args.demo_dir
        if demo_dir is None:
            from hillsim.demo import run_demo

            demo_dir = Path(tmp) / "demo"
            run_demo(demo_dir, fast=True)
        expected = blocks(demo_dir)
        text = README.read_text(encoding="utf-8")
        stale = stale_blocks(text, expected)
        if args.check:
            print("README blocks up to date" if not stale else f"stale README blocks: {', '.join(stale)}")
            return 1 if stale else 0
        for name, source in FIGURES.items():
            shutil.copyfile(Path(demo_dir) / source, REPO / "docs" / name)
            print(f"wrote docs/{name}")
        README.write_text(rewrite(text, expected), encoding="utf-8")
        print("README blocks " + (f"rewritten: {', '.join(stale)}" if stale else "already up to date"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
