"""Names a reader takes from a dataset's folder and manifest match whole: ``$`` would let a
trailing newline through."""

from __future__ import annotations

from datagen.shards import SHARD_RE, valid_writer_id


def test_writer_ids_and_shard_names_end_where_they_seem_to():
    assert valid_writer_id("w-0") and not valid_writer_id("w-0\n")
    assert SHARD_RE.match("shard-0-000001.tar") and not SHARD_RE.match("shard-0-000001.tar\n")
