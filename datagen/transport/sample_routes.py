"""Samples spread over several brokers: which broker carries a sample, and a publisher that
sends each sample to its broker.

Only the samples' bytes are spread; the control plane (commands, acks, writer status, previews)
stays on the build's one broker. A writer set subscribes to one sample broker
(``datagen writer --sample-broker URL``), so a re-issued sample reaches the writer set that may
already hold it, and that set drops the copy (docs/scale-out.md, "Several brokers").
"""

from __future__ import annotations

from collections.abc import Sequence

from datagen.sample import Sample
from datagen.transport.publisher import SamplePublisher


def broker_for(index: int, brokers: int) -> int:
    """The position, in the build's list of sample brokers, of the one that carries sample
    ``index``: ``index mod brokers``, the same on every attempt."""
    if brokers < 1:
        raise ValueError(f"need at least one sample broker, got {brokers}")
    return index % brokers


class RoutedPublisher:
    """One :class:`SamplePublisher` per sample broker (``urls``, in the build's order); sample
    ``i`` goes to ``urls[broker_for(i, len(urls))]``. The keyword arguments are each
    publisher's; with several brokers the client ids end in ``-b0``, ``-b1``, ..."""

    def __init__(self, urls: Sequence[str], build_id: str, client_id: str, **options):
        if not urls:
            raise ValueError("need at least one sample broker URL")
        self.publishers: list[SamplePublisher] = []
        try:
            for k, url in enumerate(urls):
                name = client_id if len(urls) == 1 else f"{client_id}-b{k}"
                self.publishers.append(SamplePublisher(url, build_id, name, **options))
        except BaseException:
            self._close_now()
            raise

    def __enter__(self) -> RoutedPublisher:
        return self

    def __exit__(self, exc_type, *exc) -> None:
        if exc_type is None:
            self.close()
        else:  # already failing: do not wait for PUBACKs on the way out
            self._close_now()

    @property
    def published(self) -> int:
        return sum(p.published for p in self.publishers)

    def publish(self, sample: Sample) -> None:
        """Encodes and sends ``sample`` to its broker; blocks while that broker's window is full."""
        self.publishers[broker_for(sample.index, len(self.publishers))].publish(sample)

    def flush(self) -> None:
        for publisher in self.publishers:
            publisher.flush()

    def close(self) -> None:
        try:
            self.flush()
        finally:
            self._close_now()

    def _close_now(self) -> None:
        for publisher in self.publishers:
            publisher.disconnect()
