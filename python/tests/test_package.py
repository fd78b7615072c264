"""The package as users meet it: docstring examples, type stubs against the module, strict typing
of the package and the examples, and the example scripts themselves."""

import doctest
import subprocess
import sys
from pathlib import Path

import pytest

import vadop
import vadop._vadop
import vadop.plot
import vadop.viewer

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "examples" / "python").glob("*.py"))


@pytest.mark.parametrize("module", [vadop, vadop._vadop, vadop.viewer, vadop.plot], ids=lambda m: m.__name__)
def test_docstring_examples(module):
    import matplotlib

    matplotlib.use("Agg")
    # Extension modules are not found by doctest's own search: collect their objects by hand.
    finder = doctest.DocTestFinder()
    tests = finder.find(module)
    if module is vadop._vadop:
        for name in ("World", "scene", "detect"):
            tests += finder.find(getattr(module, name), f"vadop._vadop.{name}", module=False, globs={})
    ran = 0
    for test in tests:
        result = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS).run(test)
        assert result.failed == 0, test.name
        ran += result.attempted
    assert ran > 0


def test_stubs_match_the_module():
    result = subprocess.run([sys.executable, "-m", "mypy.stubtest", "vadop._vadop"], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_package_and_examples_type_check_strictly():
    paths = [str(ROOT / "python" / "vadop"), *map(str, EXAMPLES)]
    result = subprocess.run([sys.executable, "-m", "mypy", "--strict", "--no-incremental", *paths],
                            capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr


def test_stubs_and_marker_are_installed():
    package = Path(vadop.__file__).parent
    assert (package / "py.typed").exists() and (package / "_vadop.pyi").exists()


@pytest.mark.parametrize(
    "script, args, expected",
    [
        ("bouncing_spheres.py", ["--bodies", "100", "--frames", "10"], "kinetic energy drift"),
        ("bullets_through_crowd.py", ["--crowd", "300", "--bullets", "2"], "bullet 300: touched"),
        ("detect_comparison.py", ["--bodies", "200", "--frames", "5"], "discrete"),
    ],
)
def test_example_scripts_run(script, args, expected):
    assert {p.name for p in EXAMPLES} == {"bouncing_spheres.py", "bullets_through_crowd.py", "detect_comparison.py"}
    result = subprocess.run([sys.executable, str(ROOT / "examples" / "python" / script), *args],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert expected in result.stdout
