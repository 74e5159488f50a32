"""Scan matching, association and moving-object detection from Python, on scans
ray-cast in a known room (so the true motion is known) and on a real log."""

import numpy as np
import pytest

import pgm

from test_scans import shared_data

WALLS = [((-4.0, -3.0), (6.0, -3.0)), ((6.0, -3.0), (6.0, 3.0)), ((6.0, 3.0), (-4.0, 3.0)),
         ((-4.0, 3.0), (-4.0, -3.0)), ((1.0, 1.0), (2.0, 1.5)), ((3.0, -2.0), (3.5, -0.5))]


def ray_cast(x, y, theta, beams=361, max_range=20.0, box=None):
    """A laser scan from pose (x, y, theta) in the room (and an optional square box
    (cx, cy, half side) as a moving object): ranges and angles over 180 degrees."""
    angles = np.linspace(-np.pi / 2, np.pi / 2, beams)
    walls = list(WALLS)
    if box is not None:
        cx, cy, h = box
        c = [(cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h)]
        walls += [(c[i], c[(i + 1) % 4]) for i in range(4)]
    ranges = np.full(beams, np.inf)
    for k, a in enumerate(angles):
        d = np.array([np.cos(theta + a), np.sin(theta + a)])
        for (ax, ay), (bx, by) in walls:
            e = np.array([bx - ax, by - ay])
            m = np.array([d, -e]).T
            if abs(np.linalg.det(m)) < 1e-12:
                continue
            t, u = np.linalg.solve(m, np.array([ax - x, ay - y]))
            if t > 0 and 0 <= u <= 1:
                ranges[k] = min(ranges[k], t)
    return {"ranges": ranges, "angles": angles, "max_range": max_range}


def test_icp_recovers_a_known_motion_and_the_identity():
    a = ray_cast(0.0, 0.0, 0.0)
    b = ray_cast(0.2, 0.1, 0.05)
    for matcher in ("icp", "icp+csm", "crf-matching", "joint"):
        r = pgm.match_scans(a, b, matcher=matcher)
        assert r["motion"] == pytest.approx([0.2, 0.1, 0.05], abs=0.02), matcher
    same = pgm.match_scans(a, a, matcher="icp")["motion"]
    assert same == pytest.approx([0.0, 0.0, 0.0], abs=1e-6)
    # The odometry prior is where the odometry matcher stays.
    prior = pgm.match_scans(a, b, odometry=[0.19, 0.11, 0.04], matcher="odometry")["motion"]
    assert prior == pytest.approx([0.19, 0.11, 0.04], abs=1e-12)


def test_a_moving_box_is_found_and_its_motion_estimated():
    a = ray_cast(0.0, 0.0, 0.0, box=(2.5, 0.0, 0.3))
    b = ray_cast(0.0, 0.0, 0.0, box=(2.5, 0.4, 0.3))
    r = pgm.cluster(a, b, method="crf", associations="crf-matching")
    labels = r["labels"]
    assert labels.shape == (361,)
    assert set(np.unique(labels)) <= set(range(-1, 20))
    angles = a["angles"]
    # The current box's returns: bearings towards (2.5, 0.4) within its half width.
    on_box = np.abs(angles - np.arctan2(0.4, 2.5)) < 0.08
    assert np.mean(labels[on_box] > 0) > 0.8
    assert np.mean(labels[~on_box & (labels >= 0)] == 0) > 0.95
    moving = r["motions"][r["motions"][:, 0] > 0]
    assert len(moving) >= 1
    # A cluster's motion maps its current returns onto their reference positions (the
    # convention of the ego-motion): the box moved +0.4 m in y, so (0, -0.4).
    assert moving[0, 1:3] == pytest.approx([0.0, -0.4], abs=0.1)
    alone = pgm.cluster(a, b, method="one-cluster")["labels"]
    assert set(np.unique(alone)) <= {-1, 0}


def test_associations_point_at_the_right_beams():
    a = ray_cast(0.0, 0.0, 0.0)
    b = ray_cast(0.0, 0.0, 0.0)
    for source in ("icp", "segment-icp", "crf-matching"):
        p = pgm.associate(a, b, source=source)["partners"]
        valid = np.isfinite(b["ranges"])
        assert np.all(p[~valid] == -2)
        assert np.mean(p[valid] == np.arange(361)[valid]) > 0.95, source


def test_a_real_pair_from_a_reader():
    log = pgm.read_carmen(shared_data("mit-csail", "mit-csail.clf"))
    a, b = pgm.scan(log, 100), pgm.scan(log, 101)
    prior = pgm.between(log["odometry"][100], log["odometry"][101])
    icp = pgm.match_scans(a, b, odometry=prior, matcher="icp")
    assert icp["converged"]
    # Consecutive scans of a walking-speed robot: a few centimetres and degrees.
    assert np.hypot(*icp["motion"][:2]) < 0.5 and abs(icp["motion"][2]) < 0.3
    r = pgm.cluster(a, b, odometry=prior)
    assert len(r["labels"]) == len(a["ranges"])


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda a: pgm.cluster(a, a, method="nope"), r"unknown clustering method `nope`: expected one of crf, cbd"),
        (lambda a: pgm.associate(a, a, source="nope"), r"unknown association source `nope`"),
        (lambda a: pgm.match_scans(a, a, matcher="nope"), r"unknown scan-matching method `nope`: expected one of odometry, icp"),
        (lambda a: pgm.match_scans({"ranges": np.ones(3), "angles": np.ones(2), "max_range": 5.0}, a), r"reference: 3 ranges but 2 angles"),
        (lambda a: pgm.match_scans(a, {"ranges": np.ones(3), "max_range": 5.0}), r"current: no `angles`"),
        (lambda a: pgm.match_scans(a, dict(a, valid=[True])), r"current\.valid: 1 flags for 361 beams"),
        (lambda a: pgm.match_scans(a, a, odometry=[np.nan, 0, 0]), r"odometry = \[NaN, 0\.0, 0\.0\]: expected finite numbers"),
        (lambda a: pgm.match_scans(a, a, odometry=[0.1, 0.0]), r"odometry: 2 numbers, expected 3"),
        (lambda a: pgm.match_scans(a, dict(a, max_range="80")), r"current\.max_range: .*a number of metres"),
        (lambda a: pgm.between([0, 0], [1, 1, 0]), r"between: poses are \[x, y, theta\]"),
    ],
)
def test_bad_input_is_a_pgm_error(call, message):
    with pytest.raises(pgm.PgmError, match=message):
        call(ray_cast(0.0, 0.0, 0.0))


def test_scans_from_lists():
    a = ray_cast(0.0, 0.0, 0.0)
    b = ray_cast(0.2, 0.1, 0.05)
    as_lists = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in b.items()}
    want = pgm.match_scans(a, b)["motion"]
    np.testing.assert_array_equal(pgm.match_scans(a, as_lists)["motion"], want)


def test_between_is_the_motion_in_the_first_frame():
    m = pgm.between([1.0, 2.0, np.pi / 2], [1.0, 3.0, np.pi / 2 + 0.1])
    assert m == pytest.approx([1.0, 0.0, 0.1], abs=1e-12)
    wrapped = pgm.between([0.0, 0.0, 3.1], [0.0, 0.0, -3.1])
    assert wrapped[2] == pytest.approx(2 * np.pi - 6.2, abs=1e-12)
