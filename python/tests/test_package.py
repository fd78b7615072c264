"""The package as users meet it: docstring examples, type stubs against the module, strict typing
of the package and the examples, and the example scripts themselves."""

import doctest
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

import vadop
import vadop._vadop
import vadop.plot
import vadop.viewer

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "examples" / "python").glob("*.py"))


@pytest.mark.parametrize("module", [vadop, vadop._vadop, vadop.viewer, vadop.plot], ids=lambda m: m.__name__)
def test_docstring_examples(module: ModuleType) -> None:
    import matplotlib

    matplotlib.use("Agg")
    # Extension modules are not found by doctest's own search: collect their objects by hand.
    finder = doctest.DocTestFinder()
    tests = finder.find(module)
    if module is vadop._vadop:
        for name in ("World", "Contacts", "scene", "detect"):
            tests += finder.find(getattr(module, name), f"vadop._vadop.{name}", module=False, globs={})
    ran = 0
    for test in tests:
        result = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS).run(test)
        assert result.failed == 0, test.name
        ran += result.attempted
    assert ran > 0


def test_stubs_match_the_module() -> None:
    result = subprocess.run([sys.executable, "-m", "mypy.stubtest", "vadop._vadop"], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_package_and_examples_type_check_strictly() -> None:
    paths = [str(ROOT / "python" / "vadop"), *map(str, EXAMPLES)]
    result = subprocess.run([sys.executable, "-m", "mypy", "--strict", "--no-incremental", *paths],
                            capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr


def test_stubs_and_marker_are_installed() -> None:
    package = Path(vadop.__file__).parent
    assert (package / "py.typed").exists() and (package / "_vadop.pyi").exists()


@pytest.mark.parametrize(
    "script, args, expected",
    [
        ("bouncing_spheres.py", ["--bodies", "100", "--frames", "10"], "kinetic energy drift"),
        ("bullets_through_crowd.py", ["--crowd", "300", "--bullets", "2"], "bullet 300: touched"),
        ("detect_comparison.py", ["--bodies", "200", "--frames", "5"], "discrete"),
        ("spinning_boxes.py", ["--boxes", "40", "--bullets", "2", "--frames", "10", "--out", "{page}"], "contact starts at"),
        ("debris_on_mesh.py", ["--debris", "20", "--frames", "30", "--out", "{page}"], "bounces on the terrain; kinetic energy"),
        ("granular_pile.py", ["--bodies", "120", "--frames", "120", "--out", "{page}"], "spheres lie still"),
    ],
)
def test_example_scripts_run(script: str, args: list[str], expected: str, tmp_path: Path) -> None:
    assert {p.name for p in EXAMPLES} == {"bouncing_spheres.py", "bullets_through_crowd.py", "detect_comparison.py",
                                          "spinning_boxes.py", "debris_on_mesh.py", "granular_pile.py"}
    page = tmp_path / "run.html"
    args = [arg.replace("{page}", str(page)) for arg in args]
    work = tmp_path / "work"
    work.mkdir()
    result = subprocess.run([sys.executable, str(ROOT / "examples" / "python" / script), *args],
                            capture_output=True, text=True, timeout=300, cwd=work)
    assert result.returncode == 0, result.stderr
    assert expected in result.stdout
    # The examples that write a viewer page write it where they are told, and never into the
    # working directory (pages once piled up in the clone, unignored).
    assert page.exists() == ("--out" in args)
    assert list(work.iterdir()) == []


def test_version_matches_pyproject_and_the_installed_metadata() -> None:
    import re
    from importlib.metadata import version

    pyproject = (ROOT / "pyproject.toml").read_text()
    declared = re.search(r'^version = "([^"]+)"', pyproject, re.MULTILINE)
    assert declared is not None
    assert vadop.__version__ == declared.group(1) == "0.1.0"
    assert vadop.__version__ == version("vadop")
    assert "__version__" in vadop.__all__


def test_readme_python_examples_and_plot_calls_run(monkeypatch: pytest.MonkeyPatch) -> None:
    import re

    import matplotlib

    matplotlib.use("Agg")
    readme = (ROOT / "README.md").read_text()
    section = readme.split("\n## Python\n", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, re.DOTALL)
    assert len(blocks) == 2  # spheres, then shapes
    monkeypatch.chdir(ROOT)  # the benchmark CSV's path is relative to the clone
    # Each block on its own, as a reader would paste it.
    namespaces: list[dict[str, object]] = [{} for _ in blocks]
    for block, namespace in zip(blocks, namespaces):
        exec(compile(block, "README.md", "exec"), namespace)
    # The plot calls the section shows use what the first block made.
    namespace = namespaces[0]
    calls = re.findall(r"`(vadop\.plot\.\w+\(.*?\))`", section)
    assert {c.split("(")[0] for c in calls} == {"vadop.plot.benchmark", "vadop.plot.cost_split", "vadop.plot.contact_timeline"}
    exec("import vadop.plot", namespace)
    for call in calls:
        assert eval(call, namespace) is not None, call
