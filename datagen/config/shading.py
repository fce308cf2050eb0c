"""``render.shader`` and the path tracer's keys, checked against each other and the scene."""

from __future__ import annotations

from datagen.config.sections import DENOISERS, SHADERS, RenderConfig
from datagen.errors import ConfigError


def check_shader(render: RenderConfig, scene: str, world: str | None, source: str) -> None:
    """The choices are known names; path-traced views only where a scene family renders them
    (the tabletop scenes). Whether a denoiser runs on the machine is checked where it renders
    (``datagen.sensing.path_tracing.check_denoiser``)."""
    if render.shader not in SHADERS:
        raise ConfigError(
            f"{source}: render.shader: expected one of {list(SHADERS)}, got {render.shader!r}"
        )
    if render.denoiser not in DENOISERS:
        raise ConfigError(
            f"{source}: render.denoiser: expected one of {list(DENOISERS)}, got {render.denoiser!r}"
        )
    if render.shader == "raytraced" and world != "tabletop":
        raise ConfigError(
            f"{source}: render.shader: 'raytraced' views are rendered by the tabletop scenes "
            f"(grasp_tabletop, grasp_attempts), not by scene {scene!r}; expected 'rasterized'"
        )
