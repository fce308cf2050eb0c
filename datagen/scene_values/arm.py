"""A drawn arm pose: its joint positions and, for a wrist camera that looks at the tray, where
that camera looks from and at."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from datagen.scene_values.checks import SceneValueError, fields, vector


@dataclass(frozen=True)
class WristLook:
    """The wrist camera's ``eye``, the ``target`` it looks at and the world direction its
    image's ``up`` turns towards (metres, world frame)."""

    eye: tuple[float, ...]
    target: tuple[float, ...]
    up: tuple[float, ...]

    def __post_init__(self) -> None:
        for name in ("eye", "target", "up"):
            vector(f"robot.look.{name}", getattr(self, name))

    def to_json(self) -> dict[str, Any]:
        return {"eye": list(self.eye), "target": list(self.target), "up": list(self.up)}

    @classmethod
    def from_json(cls, stored: Any, where: str = "randomisation.robot.look") -> WristLook:
        f = fields(where, stored, {"eye", "target", "up"}, set())
        return cls(*(vector(f"{where}.{name}", f[name]) for name in ("eye", "target", "up")))


@dataclass(frozen=True)
class ArmPose:
    """``qpos``: the arm's joints, then its fingers' (radians, metres), in the order of the
    arm's record's ``joint_names``; ``look``: where the wrist camera looks (``robot.pose:
    look``; the world finds the joints that put it there)."""

    qpos: tuple[float, ...]
    look: WristLook | None = None

    def __post_init__(self) -> None:
        if not 1 <= len(self.qpos) <= 64:
            raise SceneValueError(f"robot.qpos: expected 1-64 joints, got {len(self.qpos)}")
        vector("robot.qpos", self.qpos, len(self.qpos))

    def to_json(self) -> dict[str, Any]:
        stored: dict[str, Any] = {"qpos": list(self.qpos)}
        return stored | ({"look": self.look.to_json()} if self.look is not None else {})

    @classmethod
    def from_json(cls, stored: Any, where: str = "randomisation.robot") -> ArmPose:
        f = fields(where, stored, {"qpos"}, {"look"})
        qpos = f["qpos"]
        if not isinstance(qpos, list) or not 1 <= len(qpos) <= 64:
            raise SceneValueError(f"{where}.qpos: expected a list of 1-64 joint positions")
        look = WristLook.from_json(f["look"], f"{where}.look") if "look" in f else None
        return cls(vector(f"{where}.qpos", qpos, len(qpos)), look)
