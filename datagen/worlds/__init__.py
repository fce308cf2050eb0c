"""The SAPIEN worlds scene families build their samples in: the tabletop with the Panda, floor
plans with Fetch, and the robot descriptions shipped with mani-skill."""
