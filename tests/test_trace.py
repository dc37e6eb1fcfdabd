"""The Trace type: what the loop writes reads back as it was, old traces keep reading, and a
Trace refuses to hold what is not a trace.  (compare's one-line errors on bad files:
test_cli_errors.py.)"""

from dataclasses import FrozenInstanceError

import numpy as np
import pytest

from conftest import ROOT
from sim2real.errors import ConfigError
from sim2real.hardware.trace import TIME, Channel, Trace, TraceWriter, loop_channels
from sim2real.robot import load_robot

ROBOT = load_robot()
JOINTS = ROBOT.joint_names
OLD_TRACE = ROOT / "tests" / "data" / "traces" / "mock_run_24747d4.csv"  # `biped run --bus mock` at 24747d4


def write_trace(path, rows: int = 5):
    """Goals k/10, present -k/10, feet alternating, tilting up-vector: known values each tick."""
    writer = TraceWriter(path, JOINTS, {"robot": ROBOT.name, "tick_s": 0.034})
    n = len(JOINTS)
    for k in range(rows):
        writer.write(k * 0.034, k, np.full(n, k / 10), np.full(n, -k / 10), np.array([k % 2 == 0, True]),
                     np.array([0.1 * k, 0.0, 1.0]), 1e-4, 2e-3, k == 3)
    writer.close()
    return path


def test_what_the_loop_writes_reads_back_with_units_and_metadata(tmp_path):
    trace = Trace.read(write_trace(tmp_path / "t.csv"))
    assert len(trace) == 5 and trace.notes == ()
    assert trace.times == pytest.approx(np.arange(5) * 0.034)
    assert trace.goals(JOINTS) == pytest.approx(np.tile(np.arange(5)[:, None] / 10, (1, len(JOINTS))))
    assert trace.present(JOINTS)[:, 0] == pytest.approx(-np.arange(5) / 10)
    assert trace.feet.tolist() == [[True, True], [False, True], [True, True], [False, True], [True, True]]
    assert trace["up_x"] == pytest.approx(0.1 * np.arange(5)) and trace["overrun"].tolist() == [0, 0, 0, 1, 0]
    assert trace["compute_ms"] == pytest.approx(0.1) and trace["bus_ms"] == pytest.approx(2.0)
    assert trace.channels == loop_channels(JOINTS)
    assert {c.unit for c in trace.channels if c.name.endswith("_rad")} == {"rad"}
    assert trace.metadata["robot"] == ROBOT.name and "columns" not in trace.metadata
    assert trace[TIME] is trace.times and trace.missing([TIME, "tick", "nope"]) == ["nope"]


def test_a_trace_written_before_the_trace_type_reads_alike():
    trace = Trace.read(OLD_TRACE)
    assert len(trace) == 6 and trace.metadata["robot"] == "xl430_biped" and trace.notes == ()
    assert trace.channels == loop_channels(JOINTS)
    assert trace.goals(JOINTS).shape == (6, len(JOINTS)) and not np.any(trace.feet)  # the mock board's switches
    assert trace["up_z"] == pytest.approx(1.0)  # upright
    assert np.all(np.diff(trace.times) > 0) and trace["tick"].tolist() == list(range(6))


def test_a_row_cut_short_is_dropped_with_a_note(tmp_path):
    path = write_trace(tmp_path / "t.csv")
    path.write_text(path.read_text()[:-25])  # a run killed mid-row
    trace = Trace.read(path)
    assert len(trace) == 4 and len(trace.notes) == 1 and "cut short" in trace.notes[0] and str(path) in trace.notes[0]


def test_a_trace_cannot_be_changed(tmp_path):
    trace = Trace.read(write_trace(tmp_path / "t.csv"))
    with pytest.raises(ValueError):
        trace.times[0] = 1.0
    with pytest.raises(ValueError):
        trace["up_z"][0] = 0.0
    with pytest.raises(FrozenInstanceError):
        trace.times = np.zeros(5)
    with pytest.raises(TypeError):
        trace.metadata["robot"] = "other"


@pytest.mark.parametrize("times, data, channels, argument", [
    ([0.0, 0.1, 0.1], np.zeros((3, 1)), (Channel("a", "rad"),), "times"),
    ([0.0, np.nan], np.zeros((2, 1)), (Channel("a", "rad"),), "times"),
    ([], np.zeros((0, 1)), (Channel("a", "rad"),), "times"),
    ([0.0, 0.1], np.zeros((2, 2)), (Channel("a", "rad"),), "data"),
    ([0.0, 0.1], [[0.0], [np.inf]], (Channel("a", "rad"),), "data"),
    ([0.0, 0.1], np.zeros((2, 2)), (Channel("a", "rad"), Channel("a", "ms")), "channels"),
    ([0.0, 0.1], np.zeros((2, 1)), (Channel(TIME, "s"),), "channels"),
    ([0.0, 0.1], np.zeros((2, 1)), ("a",), "channels"),
], ids=["times not increasing", "times not finite", "no times", "data shape", "data not finite",
        "channel twice", "time as a channel", "channel without a unit"])
def test_a_trace_refuses_what_is_not_a_trace_naming_the_argument(times, data, channels, argument):
    with pytest.raises(ValueError, match=f"^{argument}: "):
        Trace(np.array(times), np.array(data), channels)


def test_a_csv_without_times_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("tick,up_z\n0,1\n")
    with pytest.raises(ConfigError, match="t.csv: header: has no time_s column"):
        Trace.read(path)
