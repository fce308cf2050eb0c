"""Antipodal grasps: two surface points whose normals oppose within the friction cone.

A surface point p1 is drawn area-weighted over the target's part faces; the line from p1 along
a direction drawn in the friction cone about -n1 (as Dex-Net does) is intersected with every
convex part (exactly, from the part's face planes). A parallel gripper closing on that line from
outside touches the object's extreme points on it, so p1 must be the line's first entry into the
union of parts (else it is rejected: occluded or an internal face) and p2 is its last exit, with
n2 the normal of the plane it leaves through.
The grasp closes along p2 - p1 with the grasp frame at the midpoint; the approach is drawn about
that axis, downward approaches first, and must be collision-free from the pre-grasp pose. Where
none is, the frame stands back along the approach in steps (the grasp depth, as GPD searches
it) while the contacts stay on the pads: a flat object lying in the tray is then grasped with
the fingertips clear of the floor. All approaches of a pair at one depth are collision-checked
in one batch (``GripperGeometry.collisions``).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from datagen.config.sections import CampaignConfig
from datagen.convex import BodySet, ConvexBody
from datagen.families.grasp_attempts.grasps import GraspCandidate
from datagen.families.grasp_attempts.gripper_geometry import GripperGeometry
from datagen.families.grasp_attempts.samplers.base import (
    GraspTarget,
    Obstacles,
    Reachable,
    SampleResult,
    choose_reached,
)
from datagen.grasp_model.inputs import DepthView

EPS = 1e-6  # metres


def line_interval(body: ConvexBody, origin: np.ndarray, direction: np.ndarray):
    """(t_enter, t_exit, exit plane index) of the line origin + t direction through the body,
    or None when the line misses it."""
    along = body.normals @ direction
    gap = body.offsets - body.normals @ origin  # >= 0 where origin is inside the plane
    parallel = np.abs(along) < 1e-12
    if np.any(parallel & (gap < -EPS)):
        return None
    t = np.where(parallel, 0.0, gap / np.where(parallel, 1.0, along))
    t_enter = np.max(t[along < -1e-12], initial=-np.inf)
    exits = np.where(along > 1e-12, t, np.inf)
    k = int(np.argmin(exits))
    return (t_enter, exits[k], k) if t_enter <= exits[k] + EPS else None


def _perpendicular_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u = np.cross(axis, np.eye(3)[np.argmin(np.abs(axis))])
    u /= np.linalg.norm(u)
    return u, np.cross(axis, u)


BASE_PLANE_TILT_DEG = 10.0
DEPTH_STEP = 0.002  # metres between the grasp depths tried
PAD_MARGIN = 0.003  # metres the contacts stay short of the fingertips
# a contact pair gives up to this many candidates (its clear approaches) to a sampler choosing
# among several: a pair costs many collision tests, its further approaches none
APPROACHES_PER_PAIR = 4


def _in_base_plane(centre, closing, base_xy) -> np.ndarray:
    """The approach perpendicular to ``closing`` in the vertical plane through the base and
    ``centre``, pointing down, if it is within ``BASE_PLANE_TILT_DEG`` of vertical: a
    five-joint arm reaches a low grasp from above only (measured on so100 and koch: tilted
    approaches over the tray fail IK)."""
    radial = np.array([centre[0] - base_xy[0], centre[1] - base_xy[1], 0.0])
    normal = np.cross(radial, [0.0, 0.0, 1.0])
    approach = np.cross(closing, normal)
    if np.linalg.norm(approach) < 1e-6 * np.linalg.norm(normal):
        approach = np.array([0.0, 0.0, -1.0])
    approach = approach / np.linalg.norm(approach)
    approach = approach if approach[2] <= 0 else -approach
    if approach[2] > -np.cos(np.deg2rad(BASE_PLANE_TILT_DEG)):
        return np.zeros((0, 3))
    return approach[None]


@dataclass(frozen=True)
class AntipodalSampler:
    gripper: GripperGeometry
    friction: float = 0.5  # Coulomb coefficient mu; the cone's half-angle is atan(mu)
    clearance: float = 0.01  # metres added to the contact distance for the opening width
    pregrasp_distance: float = 0.1  # metres of straight approach checked for collisions
    approach_angles: int = 24  # approach directions tried about the closing axis
    downward_z: float = -0.3  # approaches with a z component below this are tried first
    allow_side: bool = True  # then try the others (still collision-checked)
    pad_margin: float = PAD_MARGIN  # metres; a margin past the fingertips: no grasp depth
    # when the campaign checks reach: candidates drawn, of which the first reached is executed
    reach_candidates: int = 16
    name: str = "antipodal"

    @classmethod
    def from_campaign(cls, campaign: CampaignConfig, gripper: GripperGeometry) -> AntipodalSampler:
        return cls(
            gripper,
            campaign.friction,
            pregrasp_distance=campaign.pre_grasp_distance,
            reach_candidates=campaign.candidates,
        )

    @property
    def max_width(self) -> float:
        return self.gripper.max_width

    def sample(
        self,
        rng: np.random.Generator,
        target: GraspTarget,
        obstacles: Obstacles,
        max_tries: int = 200,
        view: DepthView | None = None,
        reachable: Reachable | None = None,
    ) -> SampleResult:
        if reachable is None:
            found, tries, reason = self.draw(rng, target, obstacles, 1, max_tries)
            return SampleResult(found[0] if found else None, tries, reason)
        reached = choose_reached(
            lambda: self.draw(
                rng, target, obstacles, self.reach_candidates, max_tries, APPROACHES_PER_PAIR
            ),
            lambda found: list(range(len(found))),
            reachable,
        )
        if reached.chosen < 0:
            return SampleResult(None, reached.tries, reached.reason)
        chosen = reached.drawn[reached.chosen]
        return SampleResult(chosen, reached.tries, f"the first of {len(reached.drawn)} reached")

    def draw(
        self,
        rng: np.random.Generator,
        target: GraspTarget,
        obstacles: Obstacles,
        count: int,
        max_tries: int = 200,
        per_pair: int = 1,
    ) -> tuple[list[GraspCandidate], int, str]:
        """(candidates, tries, reason): up to ``count`` candidates, each contact pair found
        giving up to ``per_pair`` of them (its clear approaches at the nearest clear depth, in
        the order tried), in at most ``max_tries`` tries: a sampler choosing among candidates
        spends no more tries than one that found none. The first candidate is :meth:`sample`'s,
        from the same ``rng``."""
        parts, bodies = target.parts_world, target.bodies
        areas = np.concatenate([part.area_faces for part in parts])
        owner = np.concatenate([np.full(len(part.faces), i) for i, part in enumerate(parts)])
        first = np.cumsum([0] + [len(part.faces) for part in parts])
        blocking = BodySet(tuple(bodies + obstacles.bodies))
        cos_cone = np.cos(np.arctan(self.friction))
        plane = target.approach_plane_through
        weights = areas
        if plane is not None:  # an approach from above closes horizontally: side faces only
            normals = np.concatenate([part.face_normals for part in parts])
            weights = np.where(np.hypot(normals[:, 0], normals[:, 1]) > cos_cone, areas, 0.0)
            if weights.sum() == 0:
                return [], 0, "no face a horizontal closing can push on"
        rejected: Counter[str] = Counter()
        found: list[GraspCandidate] = []
        tries = 0
        while len(found) < count and tries < max_tries:
            tries += 1
            face = int(rng.choice(len(areas), p=weights / weights.sum()))
            part = parts[owner[face]]
            p1 = self._point_on(rng, part.triangles[face - first[owner[face]]])
            n1 = part.face_normals[face - first[owner[face]]]
            direction = self._in_cone(rng, -n1) if plane is None else self._level(rng, -n1)
            contact = self._contact(p1, direction, bodies)
            if isinstance(contact, str):
                rejected[contact] += 1
                continue
            p2, n2 = contact
            distance = float(np.linalg.norm(p2 - p1))
            closing = (p2 - p1) / distance
            if closing @ -n1 < cos_cone or -closing @ -n2 < cos_cone:
                rejected["outside the friction cone"] += 1
                continue
            width = distance + self.clearance
            if width > self.max_width:
                rejected[f"wider than {self.max_width} m with clearance"] += 1
                continue
            clear = self._approach(rng, (p1 + p2) / 2, closing, width, blocking, obstacles, plane)
            if clear is None:
                rejected["every approach collides"] += 1
                continue
            poses, depth = clear
            info = {
                "tries": tries,
                "friction": self.friction,
                "clearance": self.clearance,
                "depth": round(depth, 6),
            }
            for pose in poses[: min(per_pair, count - len(found))]:
                found.append(GraspCandidate(pose, width, self.name, np.stack([p1, p2]), info))
        if found:
            return found, tries, "antipodal pair found"
        counts = ", ".join(f"{why}: {n}" for why, n in rejected.most_common())
        return [], tries, f"no antipodal grasp in {max_tries} tries ({counts})"

    def depths(self, width: float) -> np.ndarray:
        """Metres the grasp frame may stand back from the contacts along the approach, nearest
        first: the contacts then lie that far towards the fingertips, still on the pads
        (``pad_margin`` short of the tips). A flat object lying in the tray is grasped low
        down; standing back lifts the fingertips off the floor."""
        reach = self.gripper.tip_reach(width) - self.pad_margin
        return np.arange(0.0, max(reach, 0.0) + 1e-9, DEPTH_STEP)

    def _in_cone(self, rng: np.random.Generator, axis: np.ndarray) -> np.ndarray:
        """A direction uniform (by solid angle) in the friction cone about ``axis``."""
        cos_t = rng.uniform(np.cos(np.arctan(self.friction)), 1.0)
        phi = rng.uniform(0, 2 * np.pi)
        u, v = _perpendicular_basis(axis)
        sin_t = np.sqrt(1 - cos_t**2)
        return cos_t * axis + sin_t * (np.cos(phi) * u + np.sin(phi) * v)

    def _level(self, rng: np.random.Generator, axis: np.ndarray) -> np.ndarray:
        """A horizontal direction in the friction cone about ``axis`` (whose horizontal part
        exceeds the cone's cosine), uniform in azimuth: the closing of a five-joint arm's
        grasp from above."""
        horizontal = float(np.hypot(axis[0], axis[1]))
        half = np.arccos(min(1.0, np.cos(np.arctan(self.friction)) / horizontal))
        phi = np.arctan2(axis[1], axis[0]) + rng.uniform(-half, half)
        return np.array([np.cos(phi), np.sin(phi), 0.0])

    @staticmethod
    def _point_on(rng: np.random.Generator, triangle: np.ndarray) -> np.ndarray:
        u, v = rng.random(2)
        if u + v > 1:
            u, v = 1 - u, 1 - v
        return triangle[0] + u * (triangle[1] - triangle[0]) + v * (triangle[2] - triangle[0])

    @staticmethod
    def _contact(p1, direction, bodies):
        """(p2, n2) where the line leaves the union of parts, or why p1 is unusable."""
        hits = [(body, line_interval(body, p1, direction)) for body in bodies]
        hits = [(body, hit) for body, hit in hits if hit is not None]
        if not hits:  # numerically grazing a sliver face
            return "degenerate ray"
        if min(hit[0] for _, hit in hits) < -EPS:
            return "not the outermost surface on its line"
        body, (_, t_exit, plane) = max(hits, key=lambda item: item[1][1])
        if t_exit < 1e-4:
            return "degenerate ray"
        return p1 + t_exit * direction, body.normals[plane]

    def _approach(self, rng, centre, closing, width, blocking, obstacles, plane_through):
        """(poses, depth): the collision-free grasp frames (P, 4, 4) closing along ``closing``,
        in the order tried, standing ``depth`` metres back from ``centre`` along their
        approaches; or None. Downward approaches at every depth, nearest first, come before
        the others: an arm reaches a grasp from above far more often than one from the side."""
        u, v = _perpendicular_basis(closing)
        angles = rng.uniform(0, 2 * np.pi) + np.arange(self.approach_angles) * (
            2 * np.pi / self.approach_angles
        )
        approaches = np.cos(angles)[:, None] * u + np.sin(angles)[:, None] * v
        if plane_through is not None:
            approaches = _in_base_plane(centre, closing, plane_through)
        down = approaches[:, 2] < self.downward_z
        groups = [rng.permutation(np.flatnonzero(down))]
        if self.allow_side:
            groups.append(rng.permutation(np.flatnonzero(~down)))
        boxes = self.gripper.boxes(width, self.pregrasp_distance)
        for group in (g for g in groups if g.size):
            chosen = approaches[group]
            poses = np.zeros((len(group), 4, 4))
            poses[:, :3, 0] = np.cross(closing, chosen)
            poses[:, :3, 1] = closing
            poses[:, :3, 2] = chosen
            poses[:, 3, 3] = 1.0
            for depth in self.depths(width):  # only the position changes with the depth
                poses[:, :3, 3] = centre - depth * chosen
                hit = self.gripper.collisions(
                    poses, width, blocking, obstacles.table_z, self.pregrasp_distance, boxes
                )
                if not hit.all():
                    return poses[~hit], float(depth)
        return None
