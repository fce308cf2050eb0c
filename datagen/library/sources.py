"""What each source of the library is: a package on a registry (Debian's apt or PyPI), the
files taken from it, and their licences. Names are registered in
:data:`datagen.registries.LIBRARY_SOURCES`; the installer is :mod:`datagen.library.install`.

Only licences that allow redistributing renders made with the pictures are accepted
(:data:`REDISTRIBUTABLE`); the manifest records each file's licence and copyright line, and a
dataset's manifest lists the pictures it drew, so attribution travels with the data.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

# SPDX identifiers (and "public-domain"): each allows redistributing derived renders
REDISTRIBUTABLE = ("CC0-1.0", "public-domain", "MIT", "GPL-2.0-or-later", "CC-BY-SA-3.0")
DEBIAN_LICENCES = {"GPL-2+": "GPL-2.0-or-later", "CC-BY-SA-3.0": "CC-BY-SA-3.0"}


@dataclass(frozen=True)
class Source:
    registry: Literal["apt", "pip"]
    package: str  # pinned: "name=version" (apt) or "name==version" (pip)
    kind: Literal["photo", "artwork", "material", "mesh"]
    members: tuple[str, ...]  # fnmatch patterns of the files taken, inside the package
    url: str  # where the pictures come from upstream
    licence: str = ""  # SPDX id of every file; "" = per file from the package's debian/copyright
    copyright: str = ""  # the copyright line of every file, when licence is set
    # member -> (licence, credit), where the files' licences differ
    per_file: dict[str, tuple[str, str]] = field(default_factory=dict)


MATE_BACKGROUNDS = Source(
    registry="apt",
    package="mate-backgrounds=1.26.0-1",
    kind="photo",
    members=("usr/share/backgrounds/mate/nature/*.jpg",),
    url="https://github.com/mate-desktop/mate-backgrounds",
)

UKUI_WALLPAPERS = Source(
    registry="apt",
    package="ukui-wallpapers=20.04.3-1.1",
    kind="artwork",
    members=("usr/share/backgrounds/*.jpg", "usr/share/backgrounds/*.png"),
    url="https://github.com/ukui/ukui-wallpapers",
)

_ROBOSUITE: dict[str, Any] = {  # one wheel, one licence, for its textures and its object meshes
    "registry": "pip",
    "package": "robosuite==1.5.1",
    "url": "https://github.com/ARISE-Initiative/robosuite",
    "licence": "MIT",
    "copyright": "2022 Stanford Vision and Learning Lab and UT Robot Perception and Learning Lab",
}
ROBOSUITE_TEXTURES = Source(
    kind="material", members=("robosuite/models/assets/textures/*.png",), **_ROBOSUITE
)
ROBOSUITE_OBJECTS = Source(
    kind="mesh",
    members=tuple(
        f"robosuite/models/assets/objects/meshes/{name}.stl"
        for name in ("bottle", "bread", "can", "cereal", "lemon", "milk")
    ),
    **_ROBOSUITE,
)

_SKIMAGE = "skimage/data/"
SKIMAGE_PICTURES = (
    "astronaut.png",
    "brick.png",
    "camera.png",
    "chelsea.png",
    "coffee.png",
    "grass.png",
    "gravel.png",
    "hubble_deep_field.jpg",
    "retina.jpg",
    "rocket.jpg",
)
SKIMAGE_DATA = Source(  # licences as scikit-image's skimage/data/_fetchers.py states them
    registry="pip",
    package="scikit-image==0.25.2",
    kind="photo",
    members=tuple(_SKIMAGE + name for name in SKIMAGE_PICTURES),
    url="https://github.com/scikit-image/scikit-image/tree/main/skimage/data",
    per_file={
        _SKIMAGE + "astronaut.png": ("public-domain", "NASA (Eileen Collins)"),
        _SKIMAGE + "brick.png": ("CC0-1.0", "CC0Textures (Bricks25)"),
        _SKIMAGE + "camera.png": ("CC0-1.0", "Lav Varshney"),
        _SKIMAGE + "chelsea.png": ("CC0-1.0", "Stefan van der Walt"),
        _SKIMAGE + "coffee.png": ("CC0-1.0", "Rachel Michetti"),
        _SKIMAGE + "grass.png": ("CC0-1.0", "CC0Textures (Grass001)"),
        _SKIMAGE + "gravel.png": ("CC0-1.0", "CC0Textures (Gravel04)"),
        _SKIMAGE + "hubble_deep_field.jpg": ("public-domain", "NASA"),
        _SKIMAGE + "retina.jpg": ("CC0-1.0", "Häggström, Mikael (2014)"),
        _SKIMAGE + "rocket.jpg": ("public-domain", "SpaceX"),
    },
)
