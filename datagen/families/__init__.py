"""Scene families, one package each: ``produce.py`` (``produce(config, seed, index, attempt) ->
Sample``, in named steps: draw the values, build the world, run it, record the sample), the
family's drawn values (``values.py``) and its world (``world.py``, the one place that makes its
simulator objects), with the machinery only it uses beside them. A family's record is one line
of ``datagen.registries.FAMILIES`` (docs/extending.md adds one); what several families share
lives in the layers named for it (``worlds``, ``randomisers``, ``sensing``, ``floorplans``).

``grasp_attempts`` builds on ``grasp_tabletop`` (its scene, then a grasp executed in it); no
other family imports another.
"""
