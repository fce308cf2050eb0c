"""Path-traced colour images (``render.shader: raytraced``): each label part of a view is the
rasterized build's, byte for byte, and only the colour image differs; ``render.raytraced_share``
picks the path-traced views from their own streams, reproducibly, and each sample records which
views were path-traced. Real SAPIEN on the machine's renderer, small images at one path a pixel."""

import json
from dataclasses import replace

import pytest
import sapien

from datagen.config import BuildConfig
from datagen.errors import ConfigError
from datagen.families.grasp_tabletop.produce import produce
from datagen.sensing.path_tracing import check_denoiser, view_is_path_traced

SMALL = {"width": 64, "height": 48, "samples_per_pixel": 1, "path_depth": 1}
SEED, INDEX = 0, 0  # with a share of 0.5: the workspace view rasterized, the wrist's path-traced
LABEL_PARTS = ("depth.png", "seg.png", "semantic.png")
VIEWS = {"workspace": "", "wrist": "wrist."}  # camera -> its parts' prefix


def small_config(**render) -> BuildConfig:
    base = BuildConfig()
    return base.replace(render=replace(base.render, **SMALL, **render))


def view_shaders(sample) -> tuple[dict[str, str], dict]:
    """(camera -> its recorded shader, the metadata without them)."""
    meta = json.loads(sample.parts["json"])
    return {name: view.pop("shader") for name, view in meta["views"].items()}, meta


@pytest.fixture(scope="module")
def rasterized():
    return produce(small_config(), SEED, INDEX)


@pytest.fixture(scope="module")
def raytraced():
    return produce(small_config(shader="raytraced"), SEED, INDEX)


def test_share_picks_views_from_their_own_streams():
    render = small_config(shader="raytraced", raytraced_share=0.5).render
    views = [(index, camera) for index in range(100) for camera in VIEWS]
    picks = [view_is_path_traced(render, SEED, i, camera) for i, camera in views]
    assert picks == [view_is_path_traced(render, SEED, i, camera) for i, camera in views]
    assert 0.35 < sum(picks) / len(picks) < 0.65
    retried = [view_is_path_traced(render, SEED, i, camera, attempt=1) for i, camera in views]
    assert retried != picks  # a retry draws afresh, like every stream
    for share, expected in ((0.0, False), (1.0, True)):
        every = replace(render, raytraced_share=share)
        assert {view_is_path_traced(every, SEED, i, camera) for i, camera in views} == {expected}
    rasterized = replace(render, shader="rasterized")
    assert not any(view_is_path_traced(rasterized, SEED, i, camera) for i, camera in views)


@pytest.mark.sim
@pytest.mark.slow
def test_path_traced_views_keep_every_label(rasterized, raytraced):
    assert sorted(raytraced.parts) == sorted(rasterized.parts)
    for prefix in VIEWS.values():
        for part in LABEL_PARTS:
            assert raytraced.parts[prefix + part] == rasterized.parts[prefix + part], prefix + part
        assert raytraced.parts[prefix + "rgb.png"] != rasterized.parts[prefix + "rgb.png"]
    shaders, meta = view_shaders(raytraced)
    assert shaders == {"workspace": "raytraced", "wrist": "raytraced"}
    assert meta == json.loads(rasterized.parts["json"])  # no shader recorded in a rasterized build


@pytest.mark.sim
@pytest.mark.slow
def test_a_share_of_views_is_path_traced(rasterized, raytraced):
    config = small_config(shader="raytraced", raytraced_share=0.5)
    mixed = produce(config, SEED, INDEX)
    shaders, meta = view_shaders(mixed)
    drawn = {
        camera: "raytraced"
        if view_is_path_traced(config.render, SEED, INDEX, camera)
        else "rasterized"
        for camera in VIEWS
    }
    assert shaders == drawn == {"workspace": "rasterized", "wrist": "raytraced"}
    assert meta == json.loads(rasterized.parts["json"])
    # the rasterized view is the rasterized build's, colour and sensor depth included
    images = [
        name for name in mixed.parts if name.endswith(".png") and not name.startswith("wrist.")
    ]
    assert len(images) >= 4 and all(mixed.parts[n] == rasterized.parts[n] for n in images)
    # the same picture as where every view is path-traced: a function of the scene alone
    assert mixed.parts["wrist.rgb.png"] == raytraced.parts["wrist.rgb.png"]
    assert mixed.parts["wrist.rgb.png"] != rasterized.parts["wrist.rgb.png"]


@pytest.mark.sim
def test_a_denoiser_that_cannot_run_is_refused():
    if "llvmpipe" not in sapien.render.get_device_summary():
        pytest.skip("SAPIEN's denoisers may run on this renderer")
    with pytest.raises(ConfigError) as info:
        check_denoiser("oidn")
    assert "render.denoiser: 'oidn' does not run on this machine's renderer" in str(info.value)
    check_denoiser("none")
