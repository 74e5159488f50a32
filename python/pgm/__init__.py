"""pgm: conditional random fields and discrete factor graphs, from Rust.

Build a :class:`FactorGraph` from numpy tables (or read one from a UAI file), then
ask for the MAP assignment by max-product belief propagation (:meth:`FactorGraph.map`),
marginals by sum-product (:meth:`FactorGraph.marginals`) or the MAP assignment with
an upper bound by TRW-S (:meth:`FactorGraph.trws`). Every method runs in log space
in the Rust engine with the GIL released; results are dicts of numpy arrays.
Log-linear weights are learned by maximum pseudo-likelihood (:func:`learn`) over
:class:`FeatureSet` templates and :class:`LogLinearModel` instances.
Laser logs (CARMEN, leigh-style text exports, ROS 1 bags, MCAP) are read into numpy
by :func:`read_carmen`, :func:`read_leigh` and :func:`read_bag_scans`, their ground
truth by :func:`read_people`, :func:`read_relations` and the bag's pose and people
topics; two of their
scans (:func:`scan`) go to scan matching (:func:`match_scans`), point association
(:func:`associate`) and moving-object detection (:func:`cluster`) by any method of the
command line's registry; :class:`OnlineTracker` follows moving objects over a stream
of scans, online.
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

from importlib.metadata import PackageNotFoundError, version as _version

from ._native import (
    FactorGraph,
    FeatureSet,
    LogLinearModel,
    OnlineTracker,
    PgmError,
    associate,
    learn,
    cluster,
    match_scans,
    read_bag_scans,
    read_carmen,
    read_leigh,
    read_people,
    read_relations,
)

try:
    __version__ = _version("pgm")
except PackageNotFoundError:  # the sources, not an installed package
    __version__ = "0.0.0+unknown"

__all__ = [
    "FactorGraph",
    "FeatureSet",
    "LogLinearModel",
    "OnlineTracker",
    "PgmError",
    "associate",
    "learn",
    "cluster",
    "match_scans",
    "read_bag_scans",
    "read_carmen",
    "read_leigh",
    "read_people",
    "read_relations",
    "between",
    "scan",
]


def between(a, b):
    """The motion from pose ``a`` to pose ``b`` (each ``[x, y, theta]``) in the frame of
    ``a``, as a float64 array ``[x, y, theta]``: the odometry prior of a pair whose
    scans were taken at ``a`` and ``b`` (for a laser at the base's origin). The angle
    is wrapped to (-pi, pi]."""
    import math

    import numpy as np

    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != (3,) or b.shape != (3,):
        raise PgmError(f"between: poses are [x, y, theta], got shapes {a.shape} and {b.shape}")
    dx, dy = b[0] - a[0], b[1] - a[1]
    c, s = math.cos(a[2]), math.sin(a[2])
    dtheta = math.atan2(math.sin(b[2] - a[2]), math.cos(b[2] - a[2]))
    return np.array([c * dx + s * dy, -s * dx + c * dy, dtheta])


def scan(log, i):
    """Scan ``i`` of a reader's result (:func:`read_carmen`, :func:`read_leigh`,
    :func:`read_bag_scans`) as the dict :func:`match_scans`, :func:`associate` and
    :func:`cluster` take: ``ranges``, ``angles``, ``valid``, ``max_range``, ``stamp``."""
    return {
        "ranges": log["ranges"][i],
        "angles": log["angles"][i],
        "valid": log["valid"][i],
        "max_range": float(log["max_range"][i]),
        "stamp": float(log["stamps"][i]),
    }
