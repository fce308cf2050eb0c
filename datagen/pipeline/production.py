"""Producing one sample in a worker, under the build's error policy (``build.on_sample_error``).

A failure is retried by drawing the sample again from the streams of attempt k = 1, 2, ...
(``datagen.seeding.sample_rng``), so a retried sample is still a function of (seed, index)
alone. A sample that needed retries records them in its metadata under ``production``:
``{"attempt": k, "failures": ["attempt 0: ValueError: ...", ...]}``; a sample made at the first
attempt is byte-identical to one made without this policy.

An attempt that ran past ``build.sample_timeout_s`` (its worker was killed) is such a failure
too: the coordinator issues the sample again as a :class:`Task` starting at the next attempt and
carrying the failures so far.
"""

from __future__ import annotations

import logging
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field

from datagen.config import BuildConfig
from datagen.registries import FAMILIES
from datagen.sample import Sample
from datagen.sensing.encode import metadata_bytes

log = logging.getLogger(__name__)
MAX_ERROR_CHARS = 2000  # of each failure's message kept in metadata, manifest and reports


@dataclass(frozen=True)
class Task:
    """One sample to make: ``index``, from ``attempt`` on, after ``failures`` (one message per
    earlier attempt, e.g. one that timed out in a worker that was killed)."""

    index: int
    attempt: int = 0
    failures: tuple[str, ...] = ()


@dataclass
class Produced:
    sample: Sample
    attempt: int = 0
    failures: list[str] = field(default_factory=list)


class SampleFailed(Exception):
    """Every allowed attempt at one sample raised; ``failures`` holds one message each."""

    def __init__(self, index: int, failures: list[str]):
        super().__init__(f"sample {index} failed {len(failures)} time(s): {failures[-1]}")
        self.index, self.failures = index, failures


def _describe(attempt: int, exc: BaseException) -> str:
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    at = f" (at {where.filename.rsplit('/', 1)[-1]}:{where.lineno})" if where else ""
    return f"attempt {attempt}: {type(exc).__name__}: {exc}{at}"[:MAX_ERROR_CHARS]


def produce_with_policy(
    config: BuildConfig,
    task: Task,
    on_attempt: Callable[[int, list[str]], None] | None = None,
) -> Produced:
    """Sample ``task.index`` of the build, retried as the config allows; raises SampleFailed.
    ``on_attempt(attempt, failures so far)`` runs as each attempt starts."""
    family = FAMILIES[config.scene]
    index = task.index
    retries = config.build.retries if config.build.on_sample_error == "retry" else 0
    failures: list[str] = list(task.failures)
    for attempt in range(task.attempt, retries + 1):
        if on_attempt is not None:
            on_attempt(attempt, list(failures))
        try:
            sample = family.produce_sample(config, config.seed, index, attempt)
        except Exception as exc:  # any error of one sample: the policy decides, not the type
            failures.append(_describe(attempt, exc))
            log.warning("sample %d: %s", index, failures[-1])
            continue
        if failures:
            sample = _with_production_record(sample, attempt, failures)
        return Produced(sample, attempt, failures)
    raise SampleFailed(index, failures)


def _with_production_record(sample: Sample, attempt: int, failures: list[str]) -> Sample:
    metadata = sample.metadata
    metadata["production"] = {"attempt": attempt, "failures": failures}
    return Sample(sample.index, sample.parts | {"json": metadata_bytes(metadata)})
