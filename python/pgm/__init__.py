"""pgm: conditional random fields and discrete factor graphs, from Rust.

Build a :class:`FactorGraph` from numpy tables (or read one from a UAI file), then
ask for the MAP assignment by max-product belief propagation (:meth:`FactorGraph.map`),
marginals by sum-product (:meth:`FactorGraph.marginals`) or the MAP assignment with
an upper bound by TRW-S (:meth:`FactorGraph.trws`). Every method runs in log space
in the Rust engine with the GIL released; results are dicts of numpy arrays.
Laser logs (CARMEN, leigh-style text exports, ROS 1 bags, MCAP) are read into numpy
by :func:`read_carmen`, :func:`read_leigh` and :func:`read_bag_scans`.
Errors are raised as :class:`PgmError` (a ``ValueError``) with the message the
``pgm`` command-line tool prints.

>>> import numpy as np, pgm
>>> g = pgm.FactorGraph([2, 2])
>>> g.add_factor([0], np.array([1.0, 3.0]))
0
>>> g.add_factor([0, 1], np.array([[2.0, 1.0], [1.0, 2.0]]))
1
>>> [float(round(p, 4)) for p in g.marginals()["marginals"][0]]
[0.25, 0.75]
>>> g.map()["assignment"].tolist()
[1, 1]
"""

from ._native import FactorGraph, PgmError, read_bag_scans, read_carmen, read_leigh

__all__ = ["FactorGraph", "PgmError", "read_bag_scans", "read_carmen", "read_leigh"]
