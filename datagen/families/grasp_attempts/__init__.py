"""The grasp_attempts family: physically executed grasps with success labels, in the scene of
:mod:`datagen.families.grasp_tabletop`.

Candidate grasps come from a sampler (``samplers``, a registry), are planned (``planner``),
executed (``execute``) and labelled (``grasps``: the candidate, its outcome, the failure modes);
``produce`` records the attempt as a sample.

Grasp pose convention (ManiSkill's ``build_grasp_pose`` for the gripper's TCP link): a 4x4
world transform of the tool centre point, the point midway between the finger pads; its z axis
is the approach direction (pointing from the hand into the object), its y axis the closing
direction (the fingers move along +-y), x = y cross z. Distances in metres.
"""
