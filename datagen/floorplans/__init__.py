"""Floor plans shared by the navigation and aerial families, without the simulator: seeded
occupancy-grid layouts (``layouts``, a registry), grids (``grid``) and geodesic distances
(``geodesic``).

Conventions (all modules): an occupancy grid is a 2-D numpy bool array, True = occupied, indexed
``grid[row, col]``; world x runs along columns and y along rows; the world origin (0, 0) is the
outer corner of cell (0, 0), so cell (r, c) covers x in [c*res, (c+1)*res) and y in
[r*res, (r+1)*res), with its centre at ((c+0.5)*res, (r+0.5)*res). Rectangles are
(x0, y0, x1, y1) in world metres; yaw is in radians from +x towards +y.
"""
