"""Flight, without the simulator: 3D layouts and their voxel grids, expert trajectories
(minimum snap through planned waypoints) and the quadrotor's states by differential flatness.

Frames: world x, y as the floor plan's (metres, origin at the plan's corner), z up from the floor;
g = 9.81 m/s² along -z. Docs: docs/aerial.md.
"""
