"""inspect's summary counts targets and distractors apart (issue 39 item 14), from metadata cut
to the summary's fields as ``datagen inspect`` cuts it (pure)."""

from __future__ import annotations

from datagen.formats.frames import summary, summary_fields


def _meta(targets: list[float], distractors: list[float]) -> dict:
    seen = [{"visible_fraction": v, "role": "target", "bbox_xyxy": [0, 0, 1, 1]} for v in targets]
    seen += [{"visible_fraction": v, "role": "distractor"} for v in distractors]
    return {
        "format": "datagen.sample/1",
        "objects": [{"class": "box", "shape": {"family": "box"}, "mass": 0.1}] * len(targets),
        "views": {"workspace": {"objects": seen}},
        "randomisation": {"materials": {}, "distractors": [{}] * len(distractors)},
    }


def test_visible_fractions_are_counted_per_role():
    metas = [_meta([0.95, 0.5], [0.05, 0.05, 0.3]), _meta([1.0], [])]
    counted = summary([summary_fields(m) for m in metas])
    assert counted["visible_fraction_targets"] == {
        "0.0-0.2": 0,
        "0.2-0.4": 0,
        "0.4-0.6": 1,
        "0.6-0.8": 0,
        "0.8-1.0": 2,
    }
    assert counted["visible_fraction_distractors"] == {
        "0.0-0.2": 2,
        "0.2-0.4": 1,
        "0.4-0.6": 0,
        "0.6-0.8": 0,
        "0.8-1.0": 0,
    }
    assert "visible_fraction_histogram" not in counted  # no bin mixes the two
