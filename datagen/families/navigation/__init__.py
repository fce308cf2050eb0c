"""The navigation family: a ground robot (Fetch, the car, or a plug-in's) driving expert paths
through rooms, corridors and mazes, alone (``one_robot``) or as a fleet (``produce``)
(docs/navigation.md).

The expert needs no simulator: grid planning (``planning``), a differential-drive follower
(``follow``), Ackermann steering (``ackermann``), an episode (``episode``) and a fleet
(``fleet``); ``values`` draws the appearance, ``world`` and ``car`` build it in SAPIEN.
Floor plans themselves are shared with the aerial family: :mod:`datagen.floorplans`.
"""
