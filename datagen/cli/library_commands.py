"""``datagen library install`` and ``datagen library list``: the library of real appearance
(photographs, material pictures, meshes) that the tabletop scenes draw (``photos`` section)."""

from __future__ import annotations

import argparse
from collections import Counter

from datagen.errors import UserInputError
from datagen.library.catalogue import LibraryMissing, library_root, read_manifest
from datagen.library.install import InstallError, install
from datagen.registries import LIBRARY_SOURCES


def add_parsers(commands) -> None:
    library = commands.add_parser(
        "library",
        help="install or list the photographs, material pictures and meshes builds draw",
        description="The library of real appearance, fetched from the package registries into "
        "$DATAGEN_LIBRARY (default ~/.cache/datagen/library); docs/photo-library.md.",
    )
    actions = library.add_subparsers(dest="action", metavar="ACTION", required=True)
    add = actions.add_parser("install", help="fetch the sources (idempotent)")
    add.add_argument(
        "--sources", nargs="+", choices=list(LIBRARY_SOURCES), help="default: every source"
    )
    add.add_argument("--force", action="store_true", help="fetch again what is installed")
    add.set_defaults(run=run_install)
    show = actions.add_parser("list", help="the installed sources, files and licences")
    show.set_defaults(run=run_list)


def run_install(args: argparse.Namespace) -> int:
    try:
        install(args.sources, force=args.force, say=lambda line: print(f"datagen library: {line}"))
    except InstallError as exc:
        raise UserInputError(str(exc)) from None
    print(f"datagen library: installed in {library_root()}")
    return 0


def run_list(args: argparse.Namespace) -> int:
    try:
        manifest = read_manifest()
    except LibraryMissing as exc:
        raise UserInputError(str(exc)) from None
    print(f"library: {library_root()}")
    for name, record in LIBRARY_SOURCES.items():
        files = [f for f in manifest["files"] if f["source"] == name]
        licences = ", ".join(
            f"{n} {lic}" for lic, n in Counter(f["licence"] for f in files).items()
        )
        state = f"{len(files)} files ({licences})" if files else "not installed"
        print(f"  {name:20} {state:40} {record.summary}")
    return 0
