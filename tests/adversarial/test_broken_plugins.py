"""One broken plug-in (an installed package's entry point in a ``datagen.*`` group) is reported by
name and skipped; it never takes down commands that do not need it (issue 22, high 9).

Each test installs a real distribution the way pip leaves one (a ``*.dist-info`` folder with
``entry_points.txt`` next to its modules, on ``PYTHONPATH``) and runs the real ``datagen`` command
in a subprocess, as a user does."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.adversarial]
REPO = Path(__file__).resolve().parents[2]

# module name -> source; each breaks in its own way
MODULES = {
    "broken_raises": "raise RuntimeError('the plug-in author left a bug in')\n",
    "broken_nameless": (
        "from datagen.registries import SceneFamily\n"
        "FAMILY = SceneFamily('', 'no name', produce='x:y', classes='x:z')\n"
        "NOT_A_RECORD = object()\n"
    ),
    "broken_clash": (
        "from datagen.registries import ExportFormat, SceneFamily\n"
        "FAMILY = SceneFamily('grasp_tabletop', 'a second one', produce='x:y', classes='x:z')\n"
        "EXPORT = ExportFormat('coco', 'coco2', 'x:y')\n"
        "TWICE = ExportFormat('twice', 'twice.csv', 'x:y')\n"
    ),
}
ENTRY_POINTS = """\
[datagen.families]
missing_module = no_such_module_anywhere:FAMILY
raises_on_import = broken_raises:FAMILY
nameless = broken_nameless:FAMILY
not_a_record = broken_nameless:NOT_A_RECORD
grasp_tabletop = broken_clash:FAMILY

[datagen.exports]
coco = broken_clash:EXPORT
twice = broken_clash:TWICE
twice_again = broken_clash:TWICE
"""
BROKEN = ("missing_module", "raises_on_import", "nameless", "not_a_record", "grasp_tabletop")


@pytest.fixture
def site(tmp_path: Path) -> Path:
    """A folder holding the distribution ``broken-plugins`` and its modules."""
    folder = tmp_path / "site"
    info = folder / "broken_plugins-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-plugins\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(ENTRY_POINTS)
    for name, source in MODULES.items():
        (folder / f"{name}.py").write_text(source)
    unreadable = folder / "unreadable-0.1.dist-info"  # importlib.metadata cannot parse it
    unreadable.mkdir()
    (unreadable / "METADATA").write_text("Metadata-Version: 2.1\nName: unreadable\nVersion: 0.1\n")
    (unreadable / "entry_points.txt").write_text("[datagen.families]\na line without a name\n")
    return folder


def datagen(site: Path, *args: str) -> subprocess.CompletedProcess:
    path = os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")]))
    return subprocess.run(
        [sys.executable, "-m", "datagen.cli", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
        env=os.environ | {"PYTHONPATH": path},
    )


def reported_plugins(stderr: str) -> dict[str, str]:
    """Plug-in name -> its one report line on stderr."""
    found = {}
    for line in stderr.splitlines():
        if line.startswith("datagen: plug-in '") and "(from distribution broken-plugins" in line:
            found[line.split("'")[1]] = line
    return found


def test_version_imports_no_plugin(site):
    result = datagen(site, "--version")
    assert result.returncode == 0 and result.stdout.startswith("datagen "), result.stderr
    assert result.stderr == ""


def test_build_help_names_each_broken_plugin_once_and_lists_the_rest(site):
    result = datagen(site, "build", "--help")
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert "grasp_tabletop: annotated frames of a Panda" in " ".join(result.stdout.split())
    reports = reported_plugins(result.stderr)
    assert set(reports) >= set(BROKEN), result.stderr
    assert "no_such_module_anywhere" in reports["missing_module"]
    assert "the plug-in author left a bug in" in reports["raises_on_import"]
    assert "built-in" in reports["grasp_tabletop"]
    assert "no name" in reports["nameless"]
    assert "SceneFamily" in reports["not_a_record"]
    for name in BROKEN:
        assert result.stderr.count(f"plug-in '{name}' ") == 1, result.stderr
    unreadable = "datagen: plug-ins of distribution unreadable skipped: its entry_points.txt"
    assert result.stderr.count(unreadable) == 1, result.stderr


def test_verify_and_export_help_run_beside_broken_plugins(
    site, tmp_path, make_dataset, make_sample
):
    out = make_dataset(tmp_path / "ds", [make_sample(i) for i in range(2)])
    verified = datagen(site, "verify", out)
    assert verified.returncode == 0, verified.stderr
    assert "Traceback" not in verified.stderr
    helped = datagen(site, "export", "--help")
    assert helped.returncode == 0 and "Traceback" not in helped.stderr, helped.stderr
    reports = reported_plugins(helped.stderr)
    assert "built-in" in reports["coco"]
    assert "already registered by plug-in 'twice'" in reports["twice_again"], helped.stderr
    assert "twice" in helped.stdout  # the first of the two is kept


def test_a_config_that_needs_a_broken_plugin_says_it_failed_to_load(site, tmp_path):
    config = tmp_path / "broken.yaml"
    config.write_text("scene: raises_on_import\n")
    result = datagen(site, "build", config, "--out", tmp_path / "out", "--check")
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert str(config) in last and "scene" in last, last
    assert (
        "plug-in 'raises_on_import' (from distribution broken-plugins 0.1) failed to load" in last
    )
    assert "the plug-in author left a bug in" in last
    assert not (tmp_path / "out").exists()
