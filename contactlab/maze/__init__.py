"""The gear-shift maze of thesis 9.2: its configuration space, partitions, the generalized
damper that moves a disc through it, and the Monte Carlo forward projection (5.3.5, 10.1.1)
that turns them into a feature graph.

- :mod:`.cspace`       c-space surfaces (segments, arcs), clearance, contact states, projection
- :mod:`.partitions`   contact and back-projection partitions (5.3.3, fig 9.7)
- :mod:`.damper`       the generalized damper with Coulomb friction, vectorised over samples
- :mod:`.projection`   Monte Carlo forward projection and the feature-graph file
"""

from contactlab.maze.cspace import MazeCSpace, Surface, disc_radius
from contactlab.maze.damper import damper_paths
from contactlab.maze.partitions import ACTION_ANGLES_DEG, MazePartitions, Partition, build_partitions

__all__ = ["MazeCSpace", "Surface", "disc_radius", "damper_paths", "ACTION_ANGLES_DEG",
           "MazePartitions", "Partition", "build_partitions"]
