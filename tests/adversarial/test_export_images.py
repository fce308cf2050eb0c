"""PNG bombs in the exports (issue 38, item 3): a ``seg.png`` of 124 KB declaring 32000x32000
pixels, in a dataset that passes ``verify``, made the YOLO and COCO exports allocate 1 GB (a
``numpy`` MemoryError or ``cv2.error`` traceback under a 3 GB limit, after 15 s), and an
``rgb.png`` bomb did the same to the BOP export: they called ``cv2.imdecode`` themselves.

Now every picture datagen reads goes through one bounded decoder (``datagen.images``: the size
in the header checked before a pixel is decoded), and the export refuses the dataset in one line
naming it, the sample and the part (exit 2), keeping nothing."""

from __future__ import annotations

import pytest

from adversarial.hostile_exports import (
    GRASP_KEY,
    forged,
    grasp_source,
    png_bomb,
    real_cli,
)
from adversarial.refusals import refused
from datagen.dataset.loader import DatasetError, load

pytestmark = [pytest.mark.adversarial, pytest.mark.sim]
MEMORY = 3 * 2**30  # the command's address space: enough for datagen, not for the bomb


@pytest.fixture(scope="module")
def bomb() -> bytes:
    return png_bomb(32000, 32000)


@pytest.mark.parametrize(
    ("fmt", "part"), [("yolo", "seg.png"), ("coco", "seg.png"), ("bop", "rgb.png")]
)
def test_a_png_bomb_in_a_part_is_refused_before_it_is_decoded(
    tmp_path_factory, tmp_path, bomb, fmt, part
):
    root = forged(grasp_source(tmp_path_factory), tmp_path / "ds", parts={part: bomb})
    code, _, err = real_cli("verify", root)
    assert code == 0, err  # the shards are what the manifest says: only the picture is wrong

    result = real_cli("export", root, "--to", fmt, memory=MEMORY)
    refused(result, str(root), f"sample {GRASP_KEY}", f"{fmt} export", part, "32000x32000")
    assert not (root / fmt).exists() and not list(root.glob(f".{fmt}*"))


def test_the_loader_refuses_a_png_bomb_naming_the_part(tmp_path_factory, tmp_path, bomb):
    root = forged(grasp_source(tmp_path_factory), tmp_path / "ds", parts={"depth.png": bomb})
    with pytest.raises(DatasetError, match=r"part 'depth\.png': its header declares 32000x32000"):
        load(root)[0]
