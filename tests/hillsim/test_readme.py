"""The README's generated blocks (demo summary, linearize example) equal what the code prints now
(``docs/regenerate_readme.py`` rewrites them; this test fails when someone changes the output and not the README)."""

import importlib.util
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _script():
    spec = importlib.util.spec_from_file_location("regenerate_readme", REPO / "docs" / "regenerate_readme.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_readme_generated_blocks_are_current(demo_fast_dir):
    script = _script()
    expected = script.blocks(demo_fast_dir)
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert script.stale_blocks(text, expected) == [], "run: PYTHONPATH=. python docs/regenerate_readme.py"
    # the check can fail: an edited line of the demo summary is detected
    edited = text.replace("net fit (measured region)   ", "net fit (measured region) 1 ", 1)
    assert edited != text and script.stale_blocks(edited, expected) == ["demo-summary"]
    for name in script.FIGURES:
        assert (REPO / "docs" / name).stat().st_size > 10_000, name


def test_readme_quickstart_is_the_example_file():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    start = text.index("```python\n", text.index("`examples/quickstart.py`")) + len("```python\n")
    block = text[start:text.index("```\n", start)]
    source = (REPO / "examples" / "quickstart.py").read_text(encoding="utf-8")
    code = source[source.index('"""', 3) + 3:].lstrip("\n")  # the README shows the file without its docstring
    assert block == code
