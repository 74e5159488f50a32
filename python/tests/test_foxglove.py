"""`--mcap FILE` of `pgm track`, `pgm match`, `pgm cluster` and `pgm joint`, read with
the Python `mcap` reader (every CRC checked, seeking and streaming) and every message
validated against Foxglove's JSON Schema of its type (the `jsonschema` package): the
schema each channel names is the one stored in the file, and that is Foxglove's,
byte for byte (src/foxglove/schemas, from @foxglove/schemas)."""

import json
import pathlib
import subprocess

import numpy as np
import pytest

import pgm

from test_scans import need, shared_data
from test_tracking import pgm_binary

SCHEMAS = pathlib.Path(__file__).resolve().parents[2] / "src" / "foxglove" / "schemas"
EXPECTED = {
    "/scan": "foxglove.LaserScan",
    "/reference/scan": "foxglove.LaserScan",
    "/current/scan": "foxglove.LaserScan",
    "/tf": "foxglove.FrameTransform",
    "/tracks": "foxglove.SceneUpdate",
    "/tracks/paths": "foxglove.SceneUpdate",
    "/clusters": "foxglove.SceneUpdate",
    "/associations": "foxglove.SceneUpdate",
}


def foxglove_schema(name):
    """Foxglove's JSON Schema of message type `name` (foxglove.X), as stored."""
    return (SCHEMAS / (name.split(".")[1] + ".json")).read_text()


def read_recording(path):
    """(topic, schema name, log time, message) of every message, after checking the
    file with both of the `mcap` package's readers, CRCs validated, and every message
    against its schema."""
    reader_module = need("mcap.reader")
    jsonschema = need("jsonschema")
    messages = []
    validators = {}
    with open(path, "rb") as f:
        reader = reader_module.make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        for schema, channel, message in reader.iter_messages():
            assert channel.message_encoding == "json"
            assert schema.encoding == "jsonschema"
            assert EXPECTED[channel.topic] == schema.name
            if schema.id not in validators:
                assert schema.data.decode() == foxglove_schema(schema.name)
                validators[schema.id] = jsonschema.Draft202012Validator(json.loads(schema.data))
            decoded = json.loads(message.data)
            validators[schema.id].validate(decoded)
            messages.append((channel.topic, schema.name, message.log_time, decoded))
    assert summary.statistics.message_count == len(messages)
    with open(path, "rb") as f:
        streamed = reader_module.NonSeekingReader(f, validate_crcs=True)
        assert sum(1 for _ in streamed.iter_messages()) == len(messages)
    return messages


def on(messages, topic):
    return [m[3] for m in messages if m[0] == topic]


def test_the_validator_is_not_vacuous():
    jsonschema = need("jsonschema")
    scan = {
        "timestamp": {"sec": 1, "nsec": 0}, "frame_id": "laser",
        "pose": {"position": {"x": 0, "y": 0, "z": 0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}},
        "start_angle": -1.0, "end_angle": 1.0, "ranges": [1.0, 2.0], "intensities": [],
    }
    validator = jsonschema.Draft202012Validator(json.loads(foxglove_schema("foxglove.LaserScan")))
    validator.validate(scan)
    for broken in [
        {k: v for k, v in scan.items() if k != "ranges"},
        {**scan, "timestamp": {"sec": -1, "nsec": 0}},
        {**scan, "ranges": [1.0, None]},
    ]:
        with pytest.raises(jsonschema.ValidationError):
            validator.validate(broken)


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "pairs"
    subprocess.run([pgm_binary(), "sim", "--seed", "21", "--pairs", "1", "--out", out],
                   check=True, capture_output=True)
    return out


@pytest.mark.parametrize("command", ["match", "cluster", "joint"])
def test_pair_recordings_decode_under_foxglove_schemas(command, simulated, tmp_path):
    path = tmp_path / f"{command}.mcap"
    run = subprocess.run([pgm_binary(), command, "--pairs", simulated, "--mcap", path],
                         check=True, capture_output=True, text=True)
    printed = json.loads(run.stdout)
    messages = read_recording(path)
    topics = {m[0] for m in messages}
    assert {"/reference/scan", "/current/scan", "/tf"} <= topics
    assert ("/clusters" in topics) == (command != "match")
    assert ("/associations" in topics) == (command != "cluster")
    index = json.loads((simulated / "index.json").read_text())
    pair = json.loads((simulated / index["pairs"][0]["file"]).read_text())
    for topic, scan in [("/reference/scan", pair["reference"]), ("/current/scan", pair["current"])]:
        recorded = on(messages, topic)[0]
        np.testing.assert_array_equal(recorded["ranges"], np.where(scan["valid"], scan["ranges"], 0.0))
        assert recorded["start_angle"] == scan["angles"][0]
        assert recorded["end_angle"] == scan["angles"][-1]
    if command != "cluster":
        # One segment (two points) per current return with a reference partner.
        associated = sum(1 for a, v in zip(printed["associations"], pair["current"]["valid"]) if v and a is not None and a >= 0)
        lines = on(messages, "/associations")[0]["entities"][0]["lines"][0]
        assert len(lines["points"]) == 2 * associated > 0


@pytest.mark.parametrize("bag", ["overtake_ego.bag", "intersection.bag"])
def test_a_tracked_bag_decodes_under_foxglove_schemas(bag, tmp_path):
    path = shared_data("datmo", bag)
    mcap_path, out = tmp_path / "tracks.mcap", tmp_path / "tracks.json"
    subprocess.run(
        [pgm_binary(), "track", "--method", "crf", "--associations", "crf-matching",
         "--bag", path, "--scan-topic", "/scan", "--out", out, "--mcap", mcap_path],
        check=True, capture_output=True,
    )
    report = json.loads(out.read_text())["scans"]
    messages = read_recording(mcap_path)
    scans = on(messages, "/scan")
    assert len(scans) == len(on(messages, "/tf")) == len(on(messages, "/tracks")) == len(report)
    assert len(on(messages, "/tracks/paths")) == len(report)
    # The recorded ranges are the bag's, as the Python reader gives them (no return: 0).
    arrays = pgm.read_bag_scans(path, "/scan")
    assert len(arrays["stamps"]) == len(scans)
    for k, s in enumerate(scans):
        expected = np.where(arrays["valid"][k], arrays["ranges"][k], 0.0)
        np.testing.assert_allclose(s["ranges"], expected, rtol=0, atol=0)
        assert s["start_angle"] == pytest.approx(arrays["angles"][k][0], abs=1e-12)
        stamp = s["timestamp"]["sec"] + 1e-9 * s["timestamp"]["nsec"]
        assert stamp == pytest.approx(report[k]["time"], abs=1e-6)
    # One entity per reported track, named by its track id.
    for tracks, r in zip(on(messages, "/tracks"), report):
        shown = [f"track {o['track']}" for o in r["objects"] if o["state"] != "tentative"]
        assert [e["id"] for e in tracks["entities"]] == shown
