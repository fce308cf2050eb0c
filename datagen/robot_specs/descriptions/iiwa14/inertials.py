"""Rewrites the <inertial> of every link of iiwa14.urdf from its collision mesh: the arm's
datasheet mass (KUKA LBR iiwa 14 R820: 29.9 kg) spread over the links by mesh volume (uniform
density), centre of mass and inertia tensor (about the centre of mass, link axes) from trimesh.
The upstream file had placeholders (link_0 massless). Run once after vendoring:
``python datagen/robot_specs/descriptions/iiwa14/inertials.py``."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import trimesh

URDF = Path(__file__).with_name("iiwa14.urdf")
ARM_MASS = 29.9  # kg, KUKA LBR iiwa 14 R820 datasheet


def _meshes(root: ET.Element) -> dict[str, trimesh.Trimesh]:
    meshes = {}
    for link in root.iter("link"):
        mesh = link.find("collision/geometry/mesh")
        if mesh is not None:
            meshes[link.get("name")] = trimesh.load(URDF.parent / mesh.get("filename"))
    return meshes


def main() -> None:
    tree = ET.parse(URDF, ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    root = tree.getroot()
    meshes = _meshes(root)
    density = ARM_MASS / sum(mesh.volume for mesh in meshes.values())  # kg/m^3
    for link in root.iter("link"):
        mesh = meshes.get(link.get("name"))
        if mesh is None:
            continue
        mesh.density = density
        inertial = link.find("inertial")
        for child in list(inertial):
            inertial.remove(child)
        com = " ".join(f"{round(v, 5) + 0.0:.5f}" for v in mesh.center_mass)
        ET.SubElement(inertial, "origin", rpy="0 0 0", xyz=com)
        ET.SubElement(inertial, "mass", value=f"{mesh.mass:.4f}")
        tensor = mesh.moment_inertia  # kg m^2, about the centre of mass
        names = {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2)}
        names["izz"] = (2, 2)
        ET.SubElement(
            inertial, "inertia", {k: f"{tensor[i, j]:.6g}" for k, (i, j) in names.items()}
        )
    ET.indent(root, space="  ")
    header = URDF.read_text().partition("<robot")[0]  # the licence, outside the root element
    URDF.write_text(header + ET.tostring(root, encoding="unicode") + "\n")


if __name__ == "__main__":
    main()
