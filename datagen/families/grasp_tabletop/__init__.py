"""The grasp_tabletop family: annotated frames of an arm before a tray of objects.

``values.draw_scene`` draws every value of a scene first (each from its own stream, with the
randomisers of :mod:`datagen.randomisers`), ``world.build_scene`` builds and settles it, and
``produce`` renders and annotates its cameras.
"""
