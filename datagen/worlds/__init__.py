"""The SAPIEN worlds scene families build their samples in: the tabletop with the Panda, floor
plans with Fetch, and the robot descriptions shipped with mani-skill. The randomisers only
sample; the values they draw become SAPIEN things here, in one place (``surfaces``: materials,
textures, boxes; ``realise``: objects, rooms, lights, cameras, robot joints)."""
