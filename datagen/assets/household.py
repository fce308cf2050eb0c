"""Household-like object geometry (pure: JSON parameters in, meshes out): solids of revolution,
open vessels and swept handles, each as a smooth visual mesh plus convex parts for physics that
are built by construction (no decomposition search, so they are exact, deterministic and fast).

Part kinds (object frame, metres, the axis of revolution is z):

- ``revolve``: ``profile`` ``[[r, z], ...]`` (z non-decreasing, r >= 0) revolved about z, closed
  at both ends. Parts: one frustum per profile segment with the visual's own vertices, so the
  parts' union is exactly the visual mesh (bottles, cans).
- ``shell``: an open vessel: the outer ``profile`` (z increasing), a wall ``thickness`` and a
  ``base`` thickness. Parts: the base and a ring of ``SHELL_SECTORS`` convex wall segments per
  profile segment, circumscribing the smooth outer surface (cups, bowls).
- ``handle``: a tube of radius ``tube`` swept along an arc of radius ``radius`` centred at
  ``centre`` ``[x, z]`` in the xz plane, from ``arc_deg[0]`` to ``arc_deg[1]`` (0 = +x, 90 = +z).
  Parts: the hull of each pair of consecutive cross-sections (the visual's own vertices).
- ``prism``: a convex polygon ``polygon`` ``[[x, y], ...]`` extruded along z over ``height``,
  centred on z = 0 (boxes and lids, tool heads, blades).

Any part may carry ``offset`` and ``quat_wxyz`` (its pose in the object frame).
"""

from __future__ import annotations

import functools
import itertools
from typing import Any

import numpy as np
import trimesh
from scipy.spatial import ConvexHull

COMPOSITE_KINDS = ("revolve", "shell", "handle")  # visual mesh is not the union of the parts
REVOLVE_SECTIONS = 32  # around the axis; visual and frusta share them
SHELL_SECTORS = 12  # convex wall segments around a vessel's axis
HANDLE_SEGMENTS = 8  # along the handle's arc
TUBE_SECTIONS = 12  # around the handle's tube


def _ring(radius: float, z: float, sections: int, scale: float = 1.0) -> np.ndarray:
    """(sections, 3) points of a horizontal circle, angles 2 pi k / sections from +x (as
    ``trimesh.creation.revolve`` places them)."""
    angles = 2 * np.pi * np.arange(sections) / sections
    r = radius * scale
    return np.column_stack([r * np.cos(angles), r * np.sin(angles), np.full(sections, z)])


def _outward(points: np.ndarray, faces: np.ndarray) -> trimesh.Trimesh:
    """The convex solid with these triangles, each turned to face away from its centre."""
    faces = np.array(faces)
    triangles = points[faces]
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    inward = np.einsum("ij,ij->i", normals, triangles.mean(axis=1) - points.mean(axis=0)) < 0
    faces[inward] = faces[inward][:, ::-1]
    return trimesh.Trimesh(points, faces, process=False)


def _hull(points: np.ndarray) -> trimesh.Trimesh:
    """The convex hull of ``points`` (N, 3) (Qhull directly: a tenth of the time
    ``trimesh.convex.convex_hull`` takes)."""
    points = np.asarray(points, np.float64)
    return _outward(points, ConvexHull(points).simplices)


@functools.lru_cache(maxsize=8)
def _ring_pair_faces(n: int) -> np.ndarray:
    """Triangles of the solid between two rings of n points each (points 0..n-1, n..2n-1):
    a quad per side, a fan per end."""
    k = np.arange(n)
    k1 = (k + 1) % n
    sides = np.vstack([np.column_stack([k, k1, n + k1]), np.column_stack([k, n + k1, n + k])])
    fan = np.arange(1, n - 1)
    ends = np.vstack(
        [
            np.column_stack([np.zeros_like(fan), fan, fan + 1]),
            np.column_stack([np.full_like(fan, n), n + fan, n + fan + 1]),
        ]
    )
    return np.vstack([sides, ends])


# a wall sector's 8 corners: outer (0-3) then inner (4-7), each lower k, lower k+1, upper k,
# upper k+1; its six faces are planar (parallel chords, or a half-plane of constant angle)
_SECTOR_QUADS = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
_SECTOR_FACES = np.array([t for a, b, c, d in _SECTOR_QUADS for t in ((a, b, c), (a, c, d))])


def _rings_solid(ring_a: np.ndarray, ring_b: np.ndarray) -> trimesh.Trimesh:
    """The convex solid between two parallel rings (a frustum), built by construction."""
    points = np.vstack([ring_a, ring_b])
    if min(np.ptp(ring_a, axis=0).max(), np.ptp(ring_b, axis=0).max()) < 1e-9:
        return _hull(points)  # a ring shrunk to a point: a cone, its faces found by Qhull
    return _outward(points, _ring_pair_faces(len(ring_a)))


def _profile(spec: dict[str, Any]) -> np.ndarray:
    profile = np.asarray(spec["profile"], np.float64)
    if profile.ndim != 2 or profile.shape[1] != 2 or len(profile) < 2:
        raise ValueError(f"{spec['kind']} profile: expected [[r, z], ...] with 2+ points")
    if (profile[:, 0] < 0).any() or (np.diff(profile[:, 1]) < 0).any():
        raise ValueError(f"{spec['kind']} profile: expected r >= 0 and non-decreasing z")
    return profile


def revolve(spec: dict[str, Any]) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh]]:
    profile = _profile(spec)
    closed = np.vstack([[0.0, profile[0, 1]], profile, [0.0, profile[-1, 1]]])
    visual = trimesh.creation.revolve(closed, sections=REVOLVE_SECTIONS)
    parts = []
    for (ra, za), (rb, zb) in itertools.pairwise(profile):
        if zb - za < 1e-6 or max(ra, rb) < 1e-6:  # a step or a point: no volume of its own
            continue
        parts.append(_rings_solid(_ring(ra, za, REVOLVE_SECTIONS), _ring(rb, zb, REVOLVE_SECTIONS)))
    return visual, parts


def _inner_profile(profile: np.ndarray, thickness: float, base: float) -> np.ndarray:
    """The vessel's inside: the outer radius less the wall at each height above the base."""
    floor = profile[0, 1] + base
    z = np.maximum(profile[:, 1], floor)
    r = np.interp(z, profile[:, 1], profile[:, 0]) - thickness
    return np.column_stack([np.maximum(r, 1e-4), z])


def shell(spec: dict[str, Any]) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh]]:
    outer = _profile(spec)
    if (np.diff(outer[:, 1]) <= 0).any():
        raise ValueError("shell profile: expected increasing z")
    inner = _inner_profile(outer, spec["thickness"], spec["base"])
    closed = np.vstack([[0.0, outer[0, 1]], outer, inner[::-1], [0.0, inner[0, 1]]])
    visual = trimesh.creation.revolve(closed, sections=REVOLVE_SECTIONS)
    # circumscribed: the sectors' outer faces touch the smooth outer surface, never cut into it
    grow = 1 / np.cos(np.pi / SHELL_SECTORS)
    parts = [
        _rings_solid(
            _ring(outer[0, 0], outer[0, 1], SHELL_SECTORS, grow),
            _ring(inner[0, 0], inner[0, 1], SHELL_SECTORS),
        )
    ]
    outer_rings = [_ring(r, z, SHELL_SECTORS, grow) for r, z in outer]
    inner_rings = [_ring(r, z, SHELL_SECTORS) for r, z in inner]
    for j in range(len(outer) - 1):
        if inner[j + 1, 1] - inner[j, 1] < 1e-6:  # below the floor: the base covers it
            continue
        for k in range(SHELL_SECTORS):
            k1 = (k + 1) % SHELL_SECTORS
            rings = (outer_rings[j], outer_rings[j + 1], inner_rings[j], inner_rings[j + 1])
            corners = np.vstack([ring[[k, k1]] for ring in rings])
            parts.append(_outward(corners, _SECTOR_FACES))
    return visual, parts


def _tube_sections(spec: dict[str, Any]) -> np.ndarray:
    """(HANDLE_SEGMENTS + 1, TUBE_SECTIONS, 3) cross-section circles along the handle's arc."""
    a0, a1 = np.deg2rad(spec["arc_deg"])
    cx, cz = spec["centre"]
    sections = []
    for t in np.linspace(a0, a1, HANDLE_SEGMENTS + 1):
        radial = np.array([np.cos(t), 0.0, np.sin(t)])
        centre = np.array([cx, 0.0, cz]) + spec["radius"] * radial
        phi = 2 * np.pi * np.arange(TUBE_SECTIONS) / TUBE_SECTIONS
        circle = np.outer(np.cos(phi), radial) + np.outer(np.sin(phi), [0.0, 1.0, 0.0])
        sections.append(centre + spec["tube"] * circle)
    return np.asarray(sections)


def handle(spec: dict[str, Any]) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh]]:
    rings = _tube_sections(spec)
    n_rings, n = rings.shape[:2]
    vertices = np.vstack([rings.reshape(-1, 3), rings[0].mean(0), rings[-1].mean(0)])
    faces = []
    for i in range(n_rings - 1):
        for k in range(n):
            a, b = i * n + k, i * n + (k + 1) % n
            faces += [[a, b, b + n], [a, b + n, a + n]]
    start, end = len(vertices) - 2, len(vertices) - 1
    last = (n_rings - 1) * n
    for k in range(n):
        faces += [[start, (k + 1) % n, k], [end, last + k, last + (k + 1) % n]]
    visual = trimesh.Trimesh(vertices, np.asarray(faces), process=False)
    if visual.volume < 0:  # the arc's direction decides which way the faces were wound
        visual.invert()
    # consecutive sections differ by a shift along one direction per point: planar side quads
    parts = [_rings_solid(rings[i], rings[i + 1]) for i in range(n_rings - 1)]
    return visual, parts


def prism(spec: dict[str, Any]) -> trimesh.Trimesh:
    polygon = np.asarray(spec["polygon"], np.float64)
    half = spec["height"] / 2
    bottom = np.column_stack([polygon, np.full(len(polygon), -half)])
    top = np.column_stack([polygon, np.full(len(polygon), half)])
    return _hull(np.vstack([bottom, top]))


_BUILDERS = {"revolve": revolve, "shell": shell, "handle": handle}


def composite_part(spec: dict[str, Any]) -> tuple[trimesh.Trimesh, list[trimesh.Trimesh]]:
    """(smooth visual mesh, its convex parts) of a ``revolve``/``shell``/``handle`` part."""
    return _BUILDERS[spec["kind"]](spec)
