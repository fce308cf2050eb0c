"""One grasp attempt = one sample of a campaign.

Randomised tray scene (the grasp_tabletop scene and randomisers) -> annotated pre-grasp frame
-> target object -> grasp candidate from the configured sampler -> executed with the Panda ->
outcome label -> optional post-grasp frame. With ``campaign.record_hz`` > 0 the execution is
recorded step by step (``trajectory.npz``) and, with ``campaign.frame_hz`` > 0, filmed
(``frame<k>.rgb.png``, ``frame<k>.wrist.rgb.png``: colour only, the labels of a moving scene are
not kept). Every random choice comes from (seed, index); recording draws none. With
``campaign.grasps_per_scene`` k above 1, attempt i is tried in scene i // k, drawn from that
index, and executes the (i mod k)-th of the antipodal sampler's first k candidates there.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
import trimesh

from datagen.assets.tabletop_layout import Workspace, tray_boxes
from datagen.campaign_stats import campaign_stats
from datagen.config import BuildConfig
from datagen.config.robot import robot_spec
from datagen.config.sections import CampaignConfig
from datagen.dataset.loader import load
from datagen.families.grasp_attempts.contacts import sat_twin
from datagen.families.grasp_attempts.execute import ExecutionParams, execute_grasp
from datagen.families.grasp_attempts.grasps import GraspOutcome
from datagen.families.grasp_attempts.gripper_geometry import gripper_geometry
from datagen.families.grasp_attempts.reach import ArmReach
from datagen.families.grasp_attempts.recording import Recorder
from datagen.families.grasp_attempts.samplers import GraspTarget, Obstacles, SampleResult
from datagen.families.grasp_tabletop.produce import AnnotatedSample, annotate_scene, to_sample
from datagen.families.grasp_tabletop.values import draw_values
from datagen.families.grasp_tabletop.world import GraspScene, SceneObject, build_scene
from datagen.geometry import pose_record
from datagen.grasp_model.inputs import DepthView
from datagen.outcomes import sample_outcome
from datagen.randomisers.workspace import scaled_to_robot
from datagen.registries import SAMPLERS
from datagen.sample import Sample, sample_key
from datagen.seeding import sample_rng
from datagen.sensing.encode import png_bytes
from datagen.sensing.picture_conversion import rgb_from_colour
from datagen.sensing.render import keep_renderer_alive

MIN_VISIBLE_FRACTION = 0.3  # targets are objects the camera sees well enough to learn from


def _parts_world(obj: SceneObject) -> list[trimesh.Trimesh]:
    pose = np.asarray(obj.entity.pose.to_transformation_matrix(), float)
    return [part.copy().apply_transform(pose) for part in obj.geometry.parts]


def _in_tray(obj: SceneObject, ws: Workspace) -> bool:
    x, y, z = obj.entity.pose.p
    (cx, cy, cz), (hx, hy) = ws.tray_centre, ws.tray_inner_half
    return abs(x - cx) <= hx and abs(y - cy) <= hy and cz <= z <= cz + ws.tray_wall[1] + 0.15


def choose_target(rng: np.random.Generator, scene: GraspScene, view: dict[str, Any]) -> SceneObject:
    """A random object in the tray the workspace camera sees well; any object if there is none."""
    visible = {r["instance_id"]: r["visible_fraction"] for r in view["objects"]}
    candidates = (
        [
            o
            for o in scene.objects
            if _in_tray(o, scene.workspace)
            and visible.get(o.instance_id, 0.0) >= MIN_VISIBLE_FRACTION
        ]
        or [o for o in scene.objects if _in_tray(o, scene.workspace)]
        or scene.objects
    )
    return candidates[int(rng.integers(len(candidates)))]


def _tray_meshes(ws: Workspace) -> list[trimesh.Trimesh]:
    meshes = []
    for half, offset in tray_boxes(ws):
        box = trimesh.creation.box(extents=2 * np.asarray(half))
        box.apply_translation(np.add(offset, ws.tray_centre))
        meshes.append(box)
    return meshes


def _recorder(config: BuildConfig, scene: GraspScene, parts: dict[str, bytes]) -> Recorder | None:
    """A recorder whose frames (workspace camera, wrist camera if built) land in ``parts``."""
    campaign = config.campaign
    if campaign.record_hz <= 0:
        return None
    cameras = {
        name: scene.cameras[name] for name in ("workspace", "wrist") if name in scene.cameras
    }

    def film(k: int) -> None:
        scene.scene.update_render()  # render poses only; the physics is untouched
        for name, camera in cameras.items():
            camera.take_picture()
            rgb = rgb_from_colour(camera.get_picture("Color"))
            prefix = f"frame{k}." if name == "workspace" else f"frame{k}.{name}."
            parts[f"{prefix}rgb.png"] = png_bytes(
                cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), config.output.png_level
            )

    return Recorder(
        scene.scene.get_timestep(),
        campaign.record_hz,
        scene.spec.joint_names,
        scene.spec.arm_joints,
        campaign.frame_hz,
        film,
        "rad" if scene.spec.gripper.jaw else "m",
    )


def _approach_plane_through(scene: GraspScene) -> tuple[float, float] | None:
    """A five-joint arm's shoulder axis (world x, y), off its base's origin; None for others."""
    if not scene.spec.approach_in_base_plane:
        return None
    pan = next(j for j in scene.robot.get_active_joints() if j.name == scene.spec.arm_joints[0])
    axis = pan.get_global_pose().p
    return float(axis[0]), float(axis[1])


def _model_view(pre: AnnotatedSample, camera: str) -> DepthView:
    """The pre-grasp depth of ``camera`` as it is stored, with its calibration: what a model
    trained on the campaign's records sees."""
    return DepthView.from_record(
        pre.views[camera].depth, pre.metadata["views"][camera]["camera"], pre.metadata["robot"]
    )


def produce(config: BuildConfig, seed: int, index: int, attempt: int = 0) -> Sample:
    """A grasp attempt, in named steps as a ManiSkill task names its hooks: draw and build
    grasp_tabletop's scene (:func:`draw_values`, :func:`build_scene`, then its twin where PCM
    launches nothing: :func:`sat_twin`), observe it (:func:`annotate_scene`), choose a target
    (:func:`choose_target`), propose a grasp (:func:`propose_grasp`: the campaign's sampler),
    execute it (:func:`execute_proposal`), record the sample (:func:`attempt_record`)."""
    keep_renderer_alive()
    # with campaign.grasps_per_scene k, the scene (and every stream drawn for it) is i // k's
    scene_index, slot = divmod(index, config.campaign.grasps_per_scene)
    scene = attempt_scene(config, seed, scene_index, attempt)
    campaign, pre, target = observe_attempt(config, seed, scene_index, attempt, scene)
    if campaign.grasps_per_scene > 1:
        pre = AnnotatedSample(
            index, pre.views, pre.metadata | {"key": sample_key(index), "index": index}
        )
        result = propose_in_turn(campaign, seed, scene_index, slot, attempt, scene, target)
    else:
        result = propose_grasp(campaign, seed, index, attempt, scene, pre, target)
    recorded: dict[str, bytes] = {}  # the trajectory part and the frames
    outcome = execute_proposal(config, campaign, scene, target, result, recorded)
    record = attempt_record(campaign, seed, index, pre, target, result, outcome)
    pre.metadata["attempt"] = record
    if campaign.post_grasp_frame:
        post = annotate_scene(scene, config, seed, scene_index, ("workspace",), attempt)
        pre.views["post"] = post.views["workspace"]  # encoded as post.rgb.png, post.depth.png, ...
        record["post_view_objects"] = post.metadata["views"]["workspace"]["objects"]
    sample = to_sample(pre, config.output.png_level)
    sample.parts |= recorded
    return sample


def attempt_scene(config: BuildConfig, seed: int, index: int, attempt: int = 0) -> GraspScene:
    """The attempt's settled scene, drawn and built from (seed, index, attempt); the same
    scene again on every call (a rebuild, for a further candidate of the scene)."""
    arm = robot_spec(config.robot)  # resolved once for the sample, passed down
    values = draw_values(config, seed, index, attempt, arm)
    return sat_twin(config, build_scene(config, seed, index, attempt, values, arm))


def observe_attempt(
    config: BuildConfig, seed: int, index: int, attempt: int, scene: GraspScene
) -> tuple[CampaignConfig, AnnotatedSample, SceneObject]:
    """(campaign section scaled to the arm, pre-grasp frame, target) of the attempt's settled
    ``scene``: the attempt up to the moment a grasp is proposed."""
    campaign = scaled_to_robot(config, scene.spec).campaign  # pre-grasp and lift for a small arm
    pre = annotate_scene(scene, config, seed, index, attempt=attempt)
    workspace = pre.metadata["views"]["workspace"]
    target = choose_target(sample_rng(seed, index, "grasp_target", attempt), scene, workspace)
    return campaign, pre, target


def propose_grasp(
    campaign: CampaignConfig,
    seed: int,
    index: int,
    attempt: int,
    scene: GraspScene,
    pre: AnnotatedSample,
    target: SceneObject,
) -> SampleResult:
    """The campaign's sampler's grasp of ``target`` (stream ``grasp``), clear of the other
    objects, the tray and the table."""
    gripper = gripper_geometry(scene.spec)
    sampler = SAMPLERS[campaign.sampler].load().from_campaign(campaign, gripper)
    return sampler.sample(
        sample_rng(seed, index, "grasp", attempt),
        *grasp_problem(scene, target),
        max_tries=campaign.sampler_tries,
        view=_model_view(pre, campaign.model_camera) if campaign.sampler == "learned" else None,
        reachable=ArmReach(scene, execution_params(campaign)) if campaign.check_reach else None,
    )


def propose_in_turn(
    campaign: CampaignConfig,
    seed: int,
    scene_index: int,
    slot: int,
    attempt: int,
    scene: GraspScene,
    target: SceneObject,
) -> SampleResult:
    """The ``slot``-th of the first ``campaign.grasps_per_scene`` candidates the antipodal
    sampler draws for the scene's target (stream ``grasp`` of ``scene_index``: every attempt of
    the scene draws the same ones, the first being a one-grasp campaign's); none when the
    scene has fewer."""
    sampler = (
        SAMPLERS[campaign.sampler].load().from_campaign(campaign, gripper_geometry(scene.spec))
    )
    found, tries, reason = sampler.draw(
        sample_rng(seed, scene_index, "grasp", attempt),
        *grasp_problem(scene, target),
        campaign.grasps_per_scene,
        campaign.sampler_tries,
    )
    if slot < len(found):
        return SampleResult(found[slot], tries, f"candidate {slot} of the {len(found)} drawn")
    return SampleResult(
        None,
        tries,
        f"{reason}: {len(found)} candidates for the scene's {campaign.grasps_per_scene} attempts",
    )


def grasp_problem(scene: GraspScene, target: SceneObject) -> tuple[GraspTarget, Obstacles]:
    """What a sampler is given: the target's parts where they lie, and everything else it must
    keep clear of (the other objects, the tray and the table)."""
    obstacles = Obstacles(
        meshes_world=[p for o in scene.objects if o is not target for p in _parts_world(o)]
        + _tray_meshes(scene.workspace),
        table_z=scene.workspace.table_top,
    )
    grasp_target = GraspTarget(
        _parts_world(target),
        np.asarray(target.entity.pose.to_transformation_matrix(), float),
        _approach_plane_through(scene),
    )
    return grasp_target, obstacles


def execute_proposal(
    config: BuildConfig,
    campaign: CampaignConfig,
    scene: GraspScene,
    target: SceneObject,
    result: SampleResult,
    recorded: dict[str, bytes],
) -> GraspOutcome:
    """Executes the proposed grasp (an outcome ``no_candidate`` when the sampler found none);
    the trajectory part and film frames go into ``recorded`` when the campaign records them."""
    candidate = result.candidate
    recorder = _recorder(config, scene, recorded)
    if candidate is None:
        outcome = GraspOutcome(
            False, "no_candidate", 0.0, 0.0, {"reason": result.reason, "tries": result.tries}
        )
    else:
        params = execution_params(campaign)
        outcome = execute_grasp(scene, target.instance_id, candidate, params, recorder)
        if recorder is not None:
            recorded["trajectory.npz"] = recorder.encode()
    return outcome


def execution_params(campaign: CampaignConfig) -> ExecutionParams:
    """How a campaign executes its grasps."""
    return ExecutionParams(
        pregrasp_distance=campaign.pre_grasp_distance,
        lift_height=campaign.lift_height,
        hold_time=campaign.hold_time,
        # open to the candidate's width plus ExecutionParams.open_margin (0.01 m): 1 cm wider
        # than the opening the sampler checked for collisions (its width, contacts + clearance)
        open_fully=False,
    )


def attempt_record(
    campaign: CampaignConfig,
    seed: int,
    index: int,
    pre: AnnotatedSample,
    target: SceneObject,
    result: SampleResult,
    outcome: GraspOutcome,
) -> dict[str, Any]:
    """The sample's ``attempt``: the target, the grasp (with its pose in the workspace camera)
    and the outcome; with several grasps a scene, the scene it shares and its candidate's turn."""
    workspace = pre.metadata["views"]["workspace"]
    candidate = result.candidate
    extrinsics = np.asarray(workspace["camera"]["extrinsics_world_to_camera"])
    grasp = None
    if candidate is not None:
        grasp = candidate.to_json() | {
            "pose_camera": pose_record(extrinsics @ candidate.pose_world),
            "tries": result.tries,
        }
        grasp |= outcome.executed or {"executed_pose_world": None}  # None: never closed
    target_meta = next(o for o in pre.metadata["objects"] if o["instance_id"] == target.instance_id)
    record = {
        "attempt_id": pre.metadata["key"],
        "scene_seed": seed,
        "index": index,
        "sampler": campaign.sampler,
        "target": {
            "instance_id": target.instance_id,
            "class": target.class_name,
            "shape": target_meta["shape"],
            "mass": target_meta["mass"],
            "friction": target_meta["friction"],
            "pose_world": target_meta["pose_world"],
        },
        "grasp": grasp,
        "outcome": outcome.to_json(),
    }
    if campaign.sampler == "learned":
        record["model"] = {"sha256": campaign.model_sha256, "camera": campaign.model_camera}
    if campaign.grasps_per_scene > 1:
        scene_index, slot = divmod(index, campaign.grasps_per_scene)
        record["shared_scene"] = {
            "scene_index": scene_index,
            "candidate": slot,
            "grasps_per_scene": campaign.grasps_per_scene,
        }
    return record


def campaign_summary(out_dir: Path, made: int, seconds: float) -> dict[str, Any]:
    """Campaign statistics for the manifest (the writers know nothing of grasps)."""
    dataset = load(out_dir)
    outcomes = (sample_outcome(dataset.metadata(i)) for i in range(len(dataset)))
    stats = campaign_stats(o for o in outcomes if o is not None)  # every attempt has one
    stats["attempts_per_s"] = round(made / seconds, 4) if seconds else None
    return {"campaign": stats}
