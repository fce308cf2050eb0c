"""CPU-seconds and resident memory of the processes of a build, by role, read from /proc."""

from __future__ import annotations

import os
import threading
from pathlib import Path

TICK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    """utime + stime of a live process, seconds (0 once it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / TICK


def rss_mb(pid: int | str = "self") -> float:
    """Resident memory of a process, MB (0 once it is gone)."""
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return 0.0
    for line in text.splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return 0.0


class CpuWatch:
    """The last CPU time seen of each watched process, read every 0.2 s while it lives; and
    the resident memory of each role's processes when asked (``rss_by_role``)."""

    def __init__(self):
        self.pids: dict[int, str] = {}
        self.seen: dict[int, float] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()

    def watch(self, pid: int, role: str) -> None:
        self.pids[pid] = role

    def _loop(self) -> None:
        while not self._stop.wait(0.2):
            for pid in list(self.pids):
                self.seen[pid] = max(self.seen.get(pid, 0.0), cpu_s(pid))

    def by_role(self) -> dict[str, float]:
        self._stop.set()
        self._thread.join()
        roles: dict[str, float] = {}
        for pid, role in self.pids.items():
            roles[role] = roles.get(role, 0.0) + max(self.seen.get(pid, 0.0), cpu_s(pid))
        return roles

    def rss_by_role(self) -> dict[str, float]:
        """The largest resident set, MB, among each role's live processes now."""
        roles: dict[str, float] = {}
        for pid, role in list(self.pids.items()):
            roles[role] = round(max(roles.get(role, 0.0), rss_mb(pid)), 1)
        return roles
