"""Where a secret could leak, and a look in each: every process's command line while a build
runs, what a command printed, and every file it wrote (used by test_secrets and test_acl)."""

from __future__ import annotations

import os
import threading
from pathlib import Path
from urllib.parse import quote

# files that hold a secret by design: the build's state (the secret, for --resume)
ALLOWED_FILES = ("build.json",)


def secret_forms(passwords: list[str], secret: bytes) -> dict[str, bytes]:
    """Every form in which the given passwords and build secret could show up."""
    forms = {"build secret (hex)": secret.hex().encode(), "build secret (raw)": secret}
    forms["build secret (HEX)"] = secret.hex().upper().encode()
    for i, password in enumerate(passwords):
        forms[f"password {i}"] = password.encode()
        forms[f"password {i} (URL-encoded)"] = quote(password, safe="").encode()
    return forms


def leaks(blob: bytes | str, forms: dict[str, bytes]) -> list[str]:
    """Names of the ``forms`` found in ``blob``."""
    data = blob.encode("utf-8", "surrogateescape") if isinstance(blob, str) else blob
    return [name for name, value in forms.items() if value and value in data]


def leaking_files(out_dir: Path, forms: dict[str, bytes]) -> dict[str, list[str]]:
    """Every file under ``out_dir`` (but ``ALLOWED_FILES``) holding one of ``forms``."""
    found = {}
    for path in sorted(out_dir.rglob("*")) if out_dir.is_dir() else []:
        if not path.is_file() or path.name in ALLOWED_FILES:
            continue
        if names := leaks(path.read_bytes(), forms):
            found[str(path.relative_to(out_dir))] = names
    return found


def _read(path: str) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError:  # the process is gone, or not ours to read
        return b""


def process_table() -> dict[int, tuple[int, str]]:
    """pid -> (parent pid, command line with spaces between arguments), of every process."""
    table = {}
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            cmdline = _read(f"/proc/{entry.name}/cmdline").replace(b"\0", b" ").strip()
            stat = _read(f"/proc/{entry.name}/stat").decode(errors="replace")
            fields = stat.rpartition(")")[2].split()  # after "(comm)": state, ppid, ...
            if fields:
                table[int(entry.name)] = (int(fields[1]), cmdline.decode(errors="replace"))
    return table


def environment(pid: int) -> dict[str, str]:
    """The environment a process was started with ({} once it is gone)."""
    pairs = (item.partition(b"=") for item in _read(f"/proc/{pid}/environ").split(b"\0"))
    return {k.decode(errors="replace"): v.decode(errors="replace") for k, _, v in pairs if k}


class ProcessWatcher(threading.Thread):
    """Reads the command line of every process on the machine every ``interval_s`` until
    ``stop()``; ``seen`` maps each (pid, command line) met to its parent pid."""

    def __init__(self, interval_s: float = 0.05):
        super().__init__(daemon=True)
        self.interval_s = interval_s
        self.seen: dict[tuple[int, str], int] = {}
        self._done = threading.Event()
        self.start()

    def run(self) -> None:
        while True:
            for pid, (ppid, cmdline) in process_table().items():
                self.seen.setdefault((pid, cmdline), ppid)
            if self._done.wait(self.interval_s):
                return

    def stop(self) -> None:
        self._done.set()
        self.join(10)

    def descendants(self, root: int) -> list[str]:
        """Command lines of ``root``'s descendants seen (those whose parent was seen too)."""
        family, grew = {root}, True
        while grew:
            before = len(family)
            family |= {pid for (pid, _), ppid in self.seen.items() if ppid in family}
            grew = len(family) > before
        return [cmdline for (pid, cmdline) in self.seen if pid in family and pid != root]

    def leaking(self, forms: dict[str, bytes]) -> dict[tuple[int, str], list[str]]:
        """(pid, command line) of the processes seen with one of ``forms`` in their arguments."""
        return {key: names for key in self.seen if (names := leaks(key[1], forms))}
