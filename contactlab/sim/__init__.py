"""Physics simulator of the PHANToM + fingertip-sensor apparatus (thesis 3.4, 4.3, 7.1, 9.1).

Every thesis experiment runs on data from here, because the original
recordings are gone.  Modules, one per thing they hold:

- :mod:`~contactlab.sim.constants`    every physical constant, with its source
- :mod:`~contactlab.sim.materials`    Coulomb friction and surface texture fields
- :mod:`~contactlab.sim.environment`  planes, walls, corners, block, two-texture samples, maze
- :mod:`~contactlab.sim.dynamics`     two-mass robot/fingertip model, contacts, integrator
- :mod:`~contactlab.sim.controllers`  PD, stroke (open-loop force), integral force control
- :mod:`~contactlab.sim.sensor`       strain gauges, ADC, encoders, velocity estimate
- :mod:`~contactlab.sim.simulate`     :func:`simulate` -> :class:`SimResult`
"""

from contactlab.sim.controllers import (Exploration, IntegralForceController, Move, PositionController,
                                        StrokeController)
from contactlab.sim.dynamics import Apparatus
from contactlab.sim.environment import (ENVIRONMENTS, Environment, Plane, block, corner, free_space, maze,
                                        plane, sample_a, sample_b, wall)
from contactlab.sim.materials import MATERIALS, Material, get_material
from contactlab.sim.sensor import Encoders, StrainGaugeSensor
from contactlab.sim.simulate import SimResult, simulate

__all__ = ["Apparatus", "ENVIRONMENTS", "Encoders", "Environment", "Exploration", "IntegralForceController",
           "MATERIALS", "Material", "Move", "Plane", "PositionController", "SimResult", "StrainGaugeSensor",
           "StrokeController", "block", "corner", "free_space", "get_material", "maze", "plane", "sample_a",
           "sample_b", "simulate", "wall"]
