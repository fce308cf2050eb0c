"""Domain randomisation: pure samplers (rng and config in, typed scene values or JSON out; no
simulator, an import contract keeps it so), shared by the families. A family bundles them into
its scene's values (``datagen.families.grasp_tabletop.values.draw_scene``), each from its own
(seed, index, name) stream; the family's world builds what they describe."""
