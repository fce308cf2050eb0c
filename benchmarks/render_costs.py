"""What issue 27's render changes buy, each side by side in one process on the same scenes.

    .venv/bin/python benchmarks/render_costs.py               # 8 default scenes, 200 for lights
    .venv/bin/python benchmarks/render_costs.py --scenes 4 --light-scenes 40   # quick

1. **Robot triangles**: a default scene's steady render (the median of 3 re-renders of the built
   scene after its first) with the robot drawn with its shipped meshes (``render.robot_triangles:
   0``), at 12,000, 20,000 (the default) and 24,000 triangles, and with no robot at all; the IoU
   of each simplified robot's rendered mask with the shipped one's.
2. **Shadow filter**: the same with SAPIEN's own camera shaders (25 taps) and datagen's (9 taps),
   and the share of pixels that differ by more than one level.
3. **Light combinations**: how many combinations of light counts (per kind, and how many cast
   shadows; what SAPIEN compiles a lighting shader for) the default draws over N scenes, with the
   unlit padding lights and without them.

Results go to ``benchmarks/results/render_costs.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # as in the workers

REPO = Path(__file__).resolve().parents[1]
BUDGETS = (0, 12000, 20000, 24000)


def _steady_ms(camera) -> float:
    times = []
    for _ in range(4):
        start = time.perf_counter()
        camera.take_picture()
        camera.get_picture("Color")
        times.append(time.perf_counter() - start)
    return 1000 * statistics.median(times[1:])


def _robot_mask(scene) -> object:
    import numpy as np

    from datagen.sensing.render import capture

    frame = capture(scene.cameras["workspace"])
    return np.isin(frame.entity_ids, [link.entity.per_scene_id for link in scene.robot.get_links()])


def robot_triangles(config, scenes: int) -> dict:
    import sapien

    from datagen.families.grasp_tabletop.world import build_scene

    ms: dict[str, list[float]] = {str(b): [] for b in BUDGETS} | {"no robot": []}
    iou: dict[str, list[float]] = {str(b): [] for b in BUDGETS[1:]}
    for index in range(scenes):
        shipped = None
        for budget in BUDGETS:
            scene = build_scene(
                config.replace(render=replace(config.render, robot_triangles=budget)),
                config.seed,
                index,
            )
            scene.scene.update_render()
            ms[str(budget)].append(_steady_ms(scene.cameras["workspace"]))
            mask = _robot_mask(scene)
            if budget == 0:
                shipped = mask
            else:
                iou[str(budget)].append(float((mask & shipped).sum() / (mask | shipped).sum()))
        for link in scene.robot.get_links():
            body = link.entity.find_component_by_type(sapien.render.RenderBodyComponent)
            if body is not None:
                link.entity.remove_component(body)
        scene.scene.update_render()
        ms["no robot"].append(_steady_ms(scene.cameras["workspace"]))
    return {
        "steady_render_ms": {k: round(statistics.mean(v), 1) for k, v in ms.items()},
        "mask_iou_with_shipped": {k: round(statistics.mean(v), 4) for k, v in iou.items()},
    }


def shadow_filter(config, scenes: int) -> dict:
    import numpy as np

    from datagen.families.grasp_tabletop.world import build_scene
    from datagen.sensing import shader_pack
    from datagen.sensing.cameras import twin_camera

    ms: dict[str, list[float]] = {"sapien (25 taps)": [], "datagen (9 taps)": []}
    changed = []
    for index in range(scenes):
        scene = build_scene(config, config.seed, index)
        ours = scene.cameras["workspace"]
        theirs = twin_camera(scene.scene, ours, str(shader_pack.SAPIEN_SHADERS / "default"))
        scene.scene.update_render()
        pictures = []
        for name, camera in (("sapien (25 taps)", theirs), ("datagen (9 taps)", ours)):
            ms[name].append(_steady_ms(camera))
            pictures.append(np.round(np.clip(camera.get_picture("Color")[..., :3], 0, 1) * 255))
        changed.append(float(np.mean(np.abs(pictures[0] - pictures[1]).max(axis=-1) > 1)))
    return {
        "steady_render_ms": {k: round(statistics.mean(v), 1) for k, v in ms.items()},
        "pixels_changed_by_more_than_one_level": round(statistics.mean(changed), 4),
    }


def light_combinations(config, scenes: int) -> dict:
    import sapien

    from datagen.families.grasp_tabletop.world import build_scene

    kinds = {sapien.render.RenderDirectionalLightComponent: "directional",
             sapien.render.RenderPointLightComponent: "point", sapien.render.RenderSpotLightComponent: "spot"}  # fmt: skip

    def combination(lights) -> tuple:
        counts: dict[str, int] = {}
        for light in lights:
            kind = kinds[type(light)]
            counts[kind] = counts.get(kind, 0) + 1
            counts[kind + " shadowed"] = counts.get(kind + " shadowed", 0) + int(light.shadow)
        return tuple(sorted(counts.items()))

    padded, unpadded = set(), set()
    for index in range(scenes):
        scene = build_scene(config, config.seed, index)  # held: its lights live as long as it
        lights = scene.scene.render_system.lights
        padded.add(combination(lights))
        unpadded.add(combination([x for x in lights if any(x.color) or x.shadow]))
    return {"scenes": scenes, "without_padding": len(unpadded), "with_padding": len(padded)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=8)
    parser.add_argument("--light-scenes", type=int, default=200)
    parser.add_argument("--out", default=str(REPO / "benchmarks/results/render_costs.json"))
    args = parser.parse_args()

    from datagen.config import load_config
    from datagen.sensing.render import keep_renderer_alive

    config = load_config(REPO / "configs/grasp_tabletop.yaml")
    keep_renderer_alive()
    result = {
        "command": " ".join(sys.argv),
        "load_average": os.getloadavg(),
        "robot_triangles": robot_triangles(config, args.scenes),
        "shadow_filter": shadow_filter(config, args.scenes),
        "light_combinations": light_combinations(config, args.light_scenes),
    }
    print(json.dumps(result, indent=2))
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
