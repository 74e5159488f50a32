"""Type stubs of the compiled module (see the package docstring)."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

class PgmError(ValueError):
    """An error reported by pgm: the message names the value and where it came from."""

class FactorGraph:
    """A discrete factor graph: variables with finite cardinalities, dense table factors."""

    def __init__(self, cardinalities: Sequence[int]) -> None:
        """One variable per entry of ``cardinalities`` (each >= 1), numbered from 0."""
    @staticmethod
    def from_uai(
        path: Union[str, PathLike[str]],
        evidence: Union[str, PathLike[str], None] = None,
        sample: int = 0,
    ) -> "FactorGraph":
        """Reads a UAI model (MARKOV or BAYES) and optionally an evidence file."""
    def add_factor(
        self, scope: Sequence[int], table: npt.ArrayLike, log: bool = False
    ) -> int:
        """Adds a factor; ``table`` has one axis per scope variable (C order)."""
    @property
    def num_variables(self) -> int: ...
    @property
    def num_factors(self) -> int: ...
    @property
    def cardinalities(self) -> List[int]: ...
    def log_score(self, assignment: Sequence[int]) -> float:
        """Sum of the log-potentials of a complete assignment (-inf where a table is 0)."""
    def map(
        self,
        schedule: str = "sequential",
        damping: float = 0.0,
        tolerance: float = 1e-9,
        max_iterations: int = 1000,
    ) -> Dict[str, Any]:
        """Max-product BP: assignment, log_score, max_marginals, iterations, converged,
        residual, contradictions, seconds (the run alone). ``schedule``: flooding,
        sequential or residual."""
    def marginals(
        self,
        schedule: str = "sequential",
        damping: float = 0.0,
        tolerance: float = 1e-9,
        max_iterations: int = 1000,
    ) -> Dict[str, Any]:
        """Sum-product BP: marginals, assignment, log_score, iterations, converged,
        residual, contradictions, seconds (the run alone)."""
    def trws(self, tolerance: float = 1e-9, max_iterations: int = 1000) -> Dict[str, Any]:
        """TRW-S: assignment, log_score, bound, gap, iterations, converged, termination,
        seconds (the run alone)."""
    def to_uai(self) -> str:
        """The model in the UAI format (MARKOV)."""

ScanArrays = Dict[str, Any]

def read_carmen(path: Union[str, PathLike[str]], clock: str = "auto") -> ScanArrays:
    """CARMEN log: stamps, ranges, angles, valid, max_range, odometry, record_times,
    lines, notes. ``clock``: auto, header or record."""

def read_leigh(path: Union[str, PathLike[str]], clock: str = "auto") -> ScanArrays:
    """leigh-style scans.txt: the scan arrays plus indices, record_times, lines, notes."""

def read_bag_scans(
    path: Union[str, PathLike[str]],
    scan_topic: str,
    odom_topic: Optional[str] = None,
    ego_pose_topic: Optional[str] = None,
    object_pose_topic: Optional[str] = None,
    people_topic: Optional[str] = None,
    clock: str = "auto",
) -> ScanArrays:
    """ROS 1 bag (.bag, .bag.zip) or MCAP: the scan arrays plus record_times,
    header_stamps, frame, odom/ego_pose/object_pose with their _stamps, and
    people_times, people_ids, people_positions (annotated people)."""

def read_people(path: Union[str, PathLike[str]]) -> Dict[str, Any]:
    """leigh-gtm1 people_gt.txt: scans (scan_idx), ids, positions (n x 2, laser frame),
    lines."""

def read_relations(path: Union[str, PathLike[str]]) -> Dict[str, Any]:
    """CARMEN .relations (true motions between scans): t1, t2, motions (n x 3), lines."""

Scan = Dict[str, Any]
Pose = Sequence[float]

def match_scans(
    reference: Scan, current: Scan, odometry: Optional[Pose] = None, matcher: str = "icp"
) -> Dict[str, Any]:
    """Ego-motion of ``current`` in ``reference``'s frame: motion [x, y, theta],
    converged, iterations. ``matcher``: odometry, icp, icp+csm, crf-matching, joint."""

def associate(
    reference: Scan, current: Scan, odometry: Optional[Pose] = None, source: str = "crf-matching"
) -> Dict[str, Any]:
    """partners (reference beam per current beam, -1 outlier, -2 no return), ego_motion."""

def cluster(
    reference: Scan,
    current: Scan,
    odometry: Optional[Pose] = None,
    method: str = "crf",
    associations: str = "crf-matching",
) -> Dict[str, Any]:
    """labels (0 background, k >= 1 moving cluster, -1 no return), motions
    [[label, x, y, theta], ...], ego_motion, iterations, converged."""

class OnlineTracker:
    """Moving objects followed online over a stream of scans (as ``pgm track``)."""

    def __init__(
        self, method: str = "crf", associations: str = "crf-matching", k: Optional[int] = None
    ) -> None:
        """The detector ``method`` fed by ``associations``; ``k``: pair each scan with
        the one ``k`` scans before (default: the one about 0.3 s before)."""
    def push(self, scan: Scan) -> Dict[str, Any]:
        """The next scan (with ``stamp``, optional ``odometry``): index, time, sequence,
        pose, converged, objects (track, state, detected, centre, velocity,
        velocity_covariance, extent, score, beams)."""

class FeatureSet:
    """Named weights grouped in templates that cliques share."""

    def __init__(self, model: str, version: int = 1) -> None: ...
    def add_template(self, name: str, features: Sequence[str]) -> int:
        """One weight per feature, named "{name}.{feature}"; returns the template id."""
    @property
    def names(self) -> List[str]: ...

class LogLinearModel:
    """One instance: variables and cliques (a template and a dense feature table each)."""

    def __init__(self, feature_set: FeatureSet, cardinalities: Sequence[int]) -> None: ...
    def add_clique(self, template: int, scope: Sequence[int], features: npt.ArrayLike) -> int:
        """``features``: shape [cards of scope] + [template's features], C order."""
    def to_factor_graph(self, weights: npt.ArrayLike) -> FactorGraph: ...

def learn(
    feature_set: FeatureSet,
    instances: List[Any],
    prior_variance: float = 10.0,
    max_iterations: int = 200,
    gradient_tolerance: float = 1e-6,
    objective: str = "pl",
) -> Dict[str, Any]:
    """L-BFGS on ``objective``: "pl" (pseudo-likelihood), "ml" (maximum likelihood,
    chains and trees) or "bethe" (loopy BP's likelihood). Returns weights,
    weight_vector, objective, gradient_norm, iterations, evaluations, converged,
    termination, objective_name. ``instances``: [(model, labels), ...]."""
