"""The laser-log readers from Python: against rosbags (an independent ROS bag reader
from PyPI), against the logs' own text, and their errors.

The real logs live in ../shared/data beside the checkout (or $PGM_SHARED_DATA): without
them these tests skip, except under CI=true, where a missing data folder fails.
"""

import importlib
import os
import pathlib

import numpy as np
import pytest

import pgm


def shared_data(*parts):
    root = os.environ.get("PGM_SHARED_DATA")
    base = pathlib.Path(root) if root else pathlib.Path(__file__).resolve().parents[2] / ".." / "shared" / "data"
    path = base.joinpath(*parts)
    if not path.exists():
        if os.environ.get("CI") == "true":
            pytest.fail(f"{path} is missing, and CI always has ../shared")
        pytest.skip(f"{path} not found (../shared is not beside this checkout)")
    return path


def need(module):
    """The module (a submodule too), skipping without it; required under CI=true."""
    if os.environ.get("CI") == "true":
        return importlib.import_module(module)
    return pytest.importorskip(module)


@pytest.mark.parametrize("bag", ["overtake_ego.bag", "intersection.bag"])
def test_a_bag_read_from_python_equals_rosbags(bag):
    need("rosbags")
    from rosbags.rosbag1 import Reader
    from rosbags.typesys import Stores, get_typestore

    path = shared_data("datmo", bag)
    ours = pgm.read_bag_scans(path, "/scan", ego_pose_topic="/ego_pose", clock="header")
    store = get_typestore(Stores.ROS1_NOETIC)
    stamps, ranges, angles, record, poses, limits = [], [], [], [], [], []
    with Reader(path) as reader:
        for conn, t, raw in reader.messages():
            if conn.topic == "/scan":
                msg = store.deserialize_ros1(raw, conn.msgtype)
                stamps.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
                ranges.append(np.asarray(msg.ranges, dtype=np.float64))
                angles.append(msg.angle_min + np.arange(len(msg.ranges)) * msg.angle_increment)
                record.append(t * 1e-9)
                limits.append((msg.range_min, msg.range_max))
            elif conn.topic == "/ego_pose":
                msg = store.deserialize_ros1(raw, conn.msgtype)
                poses.append([msg.pose.position.x, msg.pose.position.y])
    assert len(stamps) == len(ours["stamps"]) > 0
    np.testing.assert_allclose(ours["stamps"], stamps, rtol=0, atol=1e-6)
    np.testing.assert_allclose(ours["record_times"], record, rtol=0, atol=1e-6)
    theirs = np.vstack(ranges)
    assert ours["ranges"].shape == theirs.shape
    # Every return the reader calls valid has the bag's range, to the bit of its float32.
    valid = ours["valid"]
    assert valid.sum() > 0.2 * valid.size
    # (The reader widens a float32 to the shortest decimal that rounds to it, 6.889
    # rather than 6.888999938964844, so compare as float32.)
    np.testing.assert_array_equal(ours["ranges"][valid].astype(np.float32), theirs[valid].astype(np.float32))
    # Beams without a return are the bag's non-finite or out-of-range values.
    low = np.array([lo for lo, _ in limits])[:, None]
    high = np.array([hi for _, hi in limits])[:, None]
    inside = np.isfinite(theirs) & (theirs > low) & (theirs < high)
    assert not np.any(inside & ~valid)
    assert np.all(theirs[valid] >= np.broadcast_to(low, theirs.shape)[valid])
    np.testing.assert_allclose(ours["angles"], np.vstack(angles), rtol=0, atol=1e-6)
    np.testing.assert_allclose(ours["ego_pose"][:, :2], np.asarray(poses), rtol=0, atol=1e-12)


def test_a_carmen_log_read_from_python_equals_its_text():
    path = shared_data("mit-csail", "mit-csail.clf")
    ours = pgm.read_carmen(path)
    lines = path.read_text().splitlines()
    assert ours["ranges"].shape == (len(ours["stamps"]), 361)
    for i in (0, len(ours["lines"]) // 2, len(ours["lines"]) - 1):
        words = lines[ours["lines"][i] - 1].split()
        assert words[0] == "FLASER"
        n = int(words[1])
        text_ranges = np.array([float(w) for w in words[2 : 2 + n]])
        got = ours["ranges"][i]
        np.testing.assert_array_equal(got[ours["valid"][i]], text_ranges[ours["valid"][i]])
        # FLASER: ranges, then x y theta (laser), odom x y theta, ipc_timestamp ...
        np.testing.assert_allclose(ours["odometry"][i], [float(w) for w in words[2 + n + 3 : 2 + n + 6]], atol=1e-9)
        assert ours["stamps"][i] == pytest.approx(float(words[2 + n + 6]), abs=1e-9)


def test_a_leigh_export_read_from_python():
    path = shared_data("leigh-gtm1", "scans.txt")
    ours = pgm.read_leigh(path)
    n = len(ours["stamps"])
    assert n > 100 and ours["ranges"].shape[0] == n
    assert np.all(np.diff(ours["stamps"]) > 0)
    assert np.all(np.diff(ours["indices"]) > 0)
    assert np.all(ours["max_range"] > 0)


def test_reader_errors_name_the_file_and_the_value(tmp_path):
    bad = tmp_path / "bad.clf"
    bad.write_text("FLASER 3 1.0 2.0\n")
    with pytest.raises(pgm.PgmError, match=r"bad\.clf"):
        pgm.read_carmen(bad)
    with pytest.raises(pgm.PgmError, match=r"clock: \"sometimes\": expected one of"):
        pgm.read_carmen(bad, clock="sometimes")
    with pytest.raises(pgm.PgmError, match=r"missing\.bag"):
        pgm.read_bag_scans(tmp_path / "missing.bag", "/scan")
    not_a_bag = tmp_path / "noise.bag"
    not_a_bag.write_bytes(b"\x00" * 64)
    with pytest.raises(pgm.PgmError, match=r"noise\.bag"):
        pgm.read_bag_scans(not_a_bag, "/scan")


def test_a_missing_topic_lists_those_the_bag_has():
    path = shared_data("datmo", "overtake_ego.bag")
    with pytest.raises(pgm.PgmError, match=r"topic /nope: no such topic in the bag; it has: /ego_pose"):
        pgm.read_bag_scans(path, "/nope")


def test_ground_truth_files_read_from_python_equal_their_text():
    people_path = shared_data("leigh-gtm1", "people_gt.txt")
    people = pgm.read_people(people_path)
    rows = [line.split() for line in people_path.read_text().splitlines() if line.startswith("PERSON")]
    assert len(rows) == len(people["ids"]) > 100
    np.testing.assert_array_equal(people["scans"], [int(r[1]) for r in rows])
    np.testing.assert_array_equal(people["ids"], [int(r[2]) for r in rows])
    np.testing.assert_array_equal(people["positions"], [[float(r[3]), float(r[4])] for r in rows])
    # Every annotation belongs to a scan of the log.
    assert set(people["scans"]) <= set(pgm.read_leigh(shared_data("leigh-gtm1", "scans.txt"))["indices"])
    relations_path = shared_data("mit-csail", "mit-csail.relations")
    relations = pgm.read_relations(relations_path)
    rows = [line.split() for line in relations_path.read_text().splitlines() if line.strip()]
    assert len(rows) == len(relations["t1"]) > 1000
    np.testing.assert_array_equal(relations["t1"], [float(r[0]) for r in rows])
    np.testing.assert_array_equal(relations["t2"], [float(r[1]) for r in rows])
    np.testing.assert_allclose(relations["motions"], [[float(r[2]), float(r[3]), float(r[7])] for r in rows], rtol=0, atol=1e-12)


def test_the_bags_people_are_the_annotations_of_its_text_export():
    bag = pgm.read_bag_scans(
        shared_data("leigh-gtm1", "general_tracking_moving_1.bag.zip"), "/scan",
        odom_topic="/odom", people_topic="/ground_truth_people_tracks",
    )
    text = pgm.read_people(shared_data("leigh-gtm1", "people_gt.txt"))
    np.testing.assert_array_equal(bag["people_ids"], text["ids"])
    # The export rounds to 0.1 mm.
    np.testing.assert_array_equal(np.round(bag["people_positions"], 4), text["positions"])
    # An annotation belongs to the last scan recorded at or before it.
    scan_of = np.searchsorted(bag["record_times"], bag["people_times"], side="right") - 1
    np.testing.assert_array_equal(scan_of, text["scans"])


def test_ground_truth_errors_name_the_file_line_and_field(tmp_path):
    people = tmp_path / "people_gt.txt"
    people.write_text("PERSON 3 1 4.0 -2.0\nPERSON 4 x 4.0 -2.0\n")
    with pytest.raises(pgm.PgmError, match=r"people_gt\.txt:2: field `person_id` = `x`"):
        pgm.read_people(people)
    relations = tmp_path / "log.relations"
    relations.write_text("1.0 2.0 0.1 0.0 0.0 0.0 0.0 nan\n")
    with pytest.raises(pgm.PgmError, match=r"log\.relations:1: field `yaw`"):
        pgm.read_relations(relations)
