"""The aerial family: quadrotors flying minimum-snap expert trajectories through 3-D corridors,
mazes and rooms (docs/aerial.md).

``produce`` draws the episode and its values, builds the volume (``world``), flies and renders
it. Flight needs no simulator: 3-D layouts and their voxel grids (``volumes``), planned
waypoints (``planning``), minimum snap (``minsnap``), the quadrotor's states by differential
flatness (``flatness``, ``fleet``) and its IMU (``imu``).

Frames: world x, y as the floor plan's (metres, origin at the plan's corner), z up from the floor;
g = 9.81 m/s² along -z.
"""
