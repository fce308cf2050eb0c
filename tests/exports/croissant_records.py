"""Run in the readers' environment: reads every record set of a ``croissant.json`` with
mlcroissant (``mlc.Dataset(path).records(record_set)``) and prints, as JSON, how many records
each yields and what its first few records hold: the key and name, an image's shape, dtype and
the sha256 of its pixels, a text file's content. Usage: python croissant_records.py PATH [N]."""

from __future__ import annotations

import hashlib
import json
import sys

import mlcroissant as mlc
import numpy as np


def _value(value):
    if hasattr(value, "mode"):  # a PIL image: mlcroissant decodes sc:ImageObject content
        pixels = np.asarray(value)
        digest = hashlib.sha256(np.ascontiguousarray(pixels).tobytes()).hexdigest()
        return {"shape": list(pixels.shape), "dtype": str(pixels.dtype), "sha256": digest}
    if isinstance(value, bytes):
        return value.decode()
    return value


def main(path: str, first: int) -> None:
    dataset = mlc.Dataset(path)
    counts, records = {}, {}
    for record_set in dataset.metadata.record_sets:
        name, kept, count = record_set.uuid, [], 0
        for record in dataset.records(name):
            count += 1
            if len(kept) < first:
                kept.append({k.split("/", 1)[1]: _value(v) for k, v in record.items()})
        counts[name], records[name] = count, kept
    print(json.dumps({"counts": counts, "records": records}))


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 2)
