"""One body across MPI ranks (the ``[mpi]`` extra: mpi4py, an MPI from wheels, pymetis).

* :mod:`.partition` - owner rank of each point (Morton ranges or METIS), ghost layers;
* :mod:`.local` - one rank's local Model (owned points + ghosts, global order kept);
* :mod:`.simulator` - :class:`DistributedSimulator`, the Simulator API over ranks;
* :mod:`.runner` - ``mpiexec -n N jellysim run scene.toml``.

Nothing here imports mpi4py at import time; see docs/mpi.md.
"""
from __future__ import annotations

from .local import LocalPart, halo_depth, replicated_reason
from .partition import halo_layers, halo_stats, partition_points, point_graph
from .simulator import DistributedSimulator, launched_under_mpi, world

__all__ = ["DistributedSimulator", "LocalPart", "halo_depth", "halo_layers", "halo_stats",
           "launched_under_mpi", "partition_points", "point_graph", "replicated_reason",
           "world"]
