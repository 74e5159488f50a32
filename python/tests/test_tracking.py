"""The online tracker from Python: scan by scan the same objects as `pgm track` on the
same bag, and the invariants a tracking metric needs."""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import pgm

from test_scans import shared_data

STATES = {"tentative", "confirmed", "coasting", "stopped"}


def pgm_binary():
    path = pathlib.Path(__file__).resolve().parents[2] / "target" / "release" / "pgm"
    if not path.exists():
        if os.environ.get("CI") == "true":
            pytest.fail(f"{path} is missing: .ci/run builds it before the Python tests")
        pytest.skip(f"{path} not built (cargo build --release)")
    return path


def track(bag_path, tracker):
    bag = pgm.read_bag_scans(bag_path, "/scan")
    return [tracker.push(pgm.scan(bag, i)) for i in range(len(bag["stamps"]))]


def test_the_python_tracker_reports_what_pgm_track_reports(tmp_path):
    path = shared_data("datmo", "overtake_ego.bag")
    out = tmp_path / "track.json"
    subprocess.run(
        [pgm_binary(), "track", "--method", "crf", "--associations", "crf-matching",
         "--bag", path, "--scan-topic", "/scan", "--out", out],
        check=True, capture_output=True,
    )
    cli = json.loads(out.read_text())["scans"]
    ours = track(path, pgm.OnlineTracker(method="crf", associations="crf-matching"))
    assert len(ours) == len(cli) == 135
    reported = 0
    for r, c in zip(ours, cli):
        assert r["time"] == pytest.approx(c["time"], abs=1e-9)
        o = r["objects"]
        assert [int(t) for t in o["track"]] == [t["track"] for t in c["objects"]]
        assert list(o["state"]) == [t["state"] for t in c["objects"]]
        for k, t in enumerate(c["objects"]):
            np.testing.assert_allclose(o["centre"][k], t["centre"], atol=1e-9)
            np.testing.assert_allclose(o["velocity"][k], t["velocity"], atol=1e-9)
            np.testing.assert_allclose(o["velocity_covariance"][k], t["velocity_covariance"], atol=1e-9)
            assert o["score"][k] == pytest.approx(t["score"], abs=1e-12)
            assert o["beams"][k].tolist() == t["beams"]
        reported += len(c["objects"])
    assert reported > 50  # the car beside the robot is followed


@pytest.mark.parametrize("bag", ["overtake_ego.bag", "intersection.bag"])
def test_reports_are_fit_for_tracking_metrics(bag):
    for r in track(shared_data("datmo", bag), pgm.OnlineTracker(method="crf")):
        o = r["objects"]
        ids = o["track"].tolist()
        assert len(ids) == len(set(ids)), "a track id twice in one scan"
        assert set(o["state"]) <= STATES
        assert np.all((o["score"] >= 0) & (o["score"] <= 1))
        assert o["centre"].shape == (len(ids), 2)
        assert o["velocity_covariance"].shape == (len(ids), 2, 2)
        for k, s in enumerate(o["state"]):
            if s == "coasting":
                assert len(o["beams"][k]) == 0 and not o["detected"][k]
            assert np.all((o["beams"][k] >= 0) & (o["beams"][k] < 360))


def test_tracker_errors():
    with pytest.raises(pgm.PgmError, match=r"unknown clustering method `nope`"):
        pgm.OnlineTracker(method="nope")
    with pytest.raises(pgm.PgmError, match=r"parameter `k` = 0: expected at least 1"):
        pgm.OnlineTracker(k=0)
    t = pgm.OnlineTracker(method="cbd")
    scan = {"ranges": np.full(10, 2.0), "angles": np.linspace(-1, 1, 10), "max_range": 8.0, "stamp": float("nan")}
    with pytest.raises(pgm.PgmError, match=r"scan: timestamp NaN is not finite"):
        t.push(scan)
    with pytest.raises(pgm.PgmError, match=r"scan\.odometry"):
        t.push(dict(scan, stamp=0.0, odometry="north"))
    with pytest.raises(pgm.PgmError, match=r"scan: no `stamp`"):
        t.push({k: v for k, v in scan.items() if k != "stamp"})
    with pytest.raises(pgm.PgmError, match=r"k = -1: expected a whole number >= 0"):
        pgm.OnlineTracker(k=-1)
