"""The architecture as docs/architecture.md describes it: small modules, no shadowed names, no
path outside the repository, and registries whose every entry loads. (Import direction and
cycles are import-linter's contracts in pyproject.toml, run by scripts/test.sh.)"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

from datagen.plugin_records import FORMAT_FUNCTIONS
from datagen.registries import (
    AIRFRAMES,
    EXECUTORS,
    EXPORTS,
    FAMILIES,
    GROUND_ROBOTS,
    LAYOUTS,
    METADATA_FORMATS,
    ROBOTS,
    SAMPLERS,
)
from datagen.registry import Registry, resolve

REPO = Path(__file__).resolve().parents[1]
MAX_MODULE_LINES = 400


def package_modules() -> list[Path]:
    return sorted((REPO / "datagen").rglob("*.py"))


def test_no_module_is_over_400_lines():
    long = {
        str(p.relative_to(REPO)): n
        for p in package_modules()
        if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES
    }
    assert not long, f"split these modules: {long}"


def test_no_module_shadows_a_standard_or_installed_module():
    taken = set(sys.stdlib_module_names) | set(metadata.packages_distributions())
    shadowing = [
        str(p.relative_to(REPO))
        for p in package_modules()
        if p.stem in taken and p.stem not in ("__init__", "__main__")
    ]
    assert not shadowing, f"rename these modules: {shadowing}"


def test_no_module_imports_another_modules_private_names():
    offenders = [
        f"{path.relative_to(REPO)}:{node.lineno} {alias.name} from {node.module}"
        for path in package_modules()
        for node in ast.walk(ast.parse(path.read_text()))
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("datagen")
        for alias in node.names
        if alias.name.startswith("_") and not alias.name.startswith("__")
    ]
    assert not offenders, offenders


def test_no_tracked_file_names_a_path_outside_the_repository():
    files = subprocess.run(
        ["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True
    ).stdout.split()
    # spelt in pieces so that this file does not name them itself
    outside = ("/" + "work/", "shared" + "/notes", ".." + "/shared")
    offenders = [
        f
        for f in files
        if (REPO / f).is_file()
        and (REPO / f).suffix in (".py", ".md", ".sh", ".toml", ".yaml", ".ipynb", ".txt", "")
        and any(o in (REPO / f).read_text(errors="replace") for o in outside)
    ]
    assert not offenders, offenders


def test_registry_names_are_well_formed():
    for registry in (FAMILIES, SAMPLERS, EXPORTS, EXECUTORS, LAYOUTS):
        names = registry.names()
        assert names and all(n.isidentifier() for n in names), names


def test_a_registry_refuses_a_name_listed_twice():
    # a table is built from a list, so a duplicate cannot vanish into a dict key unseen
    record = next(iter(SAMPLERS.values()))
    with pytest.raises(ValueError, match=f"{record.name} listed more than once"):
        Registry("grasp sampler", "datagen.test-none", [record, record])


@pytest.mark.sim
def test_every_registry_entry_loads():
    for family in FAMILIES.values():
        for ref in filter(None, (family.produce, family.classes, family.finish)):
            assert callable(resolve(ref)), ref
    for export in EXPORTS.values():
        assert callable(resolve(export.export))
    for plugin in (*SAMPLERS.values(), *EXECUTORS.values()):
        assert callable(plugin.load())
    for layout in LAYOUTS.values():
        assert callable(resolve(layout.make)) and callable(resolve(layout.params))
    for arm in ROBOTS.values():  # the name is the record's own, written once more for laziness
        assert arm.load().name == arm.name
    for robot in GROUND_ROBOTS.values():
        assert all(callable(resolve(ref)) for ref in (robot.drive, robot.body, robot.describe))
    for airframe in AIRFRAMES.values():
        assert all(
            callable(resolve(ref)) for ref in (airframe.shape, airframe.parts, airframe.mounts)
        )
    for fmt in METADATA_FORMATS.values():
        assert all(callable(fmt.function(name)) for name in FORMAT_FUNCTIONS), fmt.name


def test_every_family_writes_registered_metadata_formats():
    for family in FAMILIES.values():
        assert family.metadata_formats, family.name
        assert set(family.metadata_formats) <= set(METADATA_FORMATS), family.name


def _architecture_tables():
    sys.path.insert(0, str(REPO / "docs" / "hooks"))
    try:
        import architecture_tables
    finally:
        sys.path.pop(0)
    return architecture_tables


def test_the_layer_and_module_tables_of_the_docs_are_generated_from_the_code():
    tables = _architecture_tables()
    doc = (REPO / "docs" / "architecture.md").read_text()
    assert tables.LAYER_MARKER in doc and tables.MODULE_MARKER in doc
    layer_rows = re.findall(r"^\| (\d*) \| `([\w.]+)` \| (.+) \|$", tables.layer_table(), re.M)
    assert [n for n in tables.layers() for n in n] == [name for _, name, _ in layer_rows]
    assert [int(n) for n, _, _ in layer_rows if n] == list(range(1, len(tables.layers()) + 1))
    modules = {
        p.relative_to(REPO / "datagen").as_posix()
        for p in (REPO / "datagen").rglob("*.py")
        if p.name != "__init__.py" and "__pycache__" not in p.parts
    }
    listed, package = set(), ""
    for where, name, job in re.findall(
        r"^\| (`[\w/]+/`)? ?\| `(\w+\.py)` \| (.+) \|$", tables.module_table(), re.M
    ):
        package = where.strip("`").removeprefix("datagen/") if where else package
        listed.add(package + name)
        assert job.strip()
    assert listed == modules


def test_every_path_the_data_flow_picture_names_exists():
    doc = (REPO / "docs" / "architecture.md").read_text()
    picture = doc.split("## Data flow and modules", 1)[1].split("```", 2)[1]
    named = re.findall(r"[\w<>]+/[\w/<>]*(?:\.py|/)?(?=[\s:),]|$)", picture, re.M)
    assert len(named) > 10
    for name in named:
        base = REPO / ("" if name.startswith("configs") else "datagen")
        assert (base / name).exists() or list(base.glob(name.replace("<family>", "*"))), name


def test_the_command_line_starts_without_the_geometry_or_the_simulator():
    # every `datagen ...` pays for what its import pulls in, before it does anything
    heavy = ("trimesh", "sapien", "mani_skill", "torch", "open3d", "pxr", "ray", "h5py")
    code = f"import sys, datagen.cli; print([m for m in {heavy!r} if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_every_error_the_command_line_reports_is_one_datagen_error():
    from datagen.errors import (
        BuildError,
        ConfigError,
        DatagenError,
        DatasetError,
        OutDirError,
        UserInputError,
    )
    from datagen.transport.connection import MqttConnectError
    from datagen.transport.mosquitto import BrokerError

    reported = (ConfigError, OutDirError, UserInputError, DatasetError, BuildError, BrokerError)
    assert all(issubclass(kind, DatagenError) for kind in (*reported, MqttConnectError))
    assert {kind.exit_status for kind in (ConfigError, OutDirError, UserInputError)} == {2}
    assert {kind.exit_status for kind in (DatasetError, BuildError, BrokerError)} == {1}
    cli = (REPO / "datagen" / "cli" / "__init__.py").read_text()
    assert "except DatagenError as exc:" in cli and "except (BuildError" not in cli


def test_a_function_named_sample_is_about_a_dataset_sample_never_a_random_draw():
    # "sample" is the dataset item; what draws random values is draw_* (or says what it adds)
    drawing = []
    for path in (REPO / "datagen").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            named = isinstance(node, ast.FunctionDef) and node.name.startswith("sample_")
            if named and any(a.arg == "rng" for a in node.args.args):
                drawing.append(f"{path.relative_to(REPO)}:{node.name}")
    assert drawing == []
