"""Hostile input and output (issue 47, items 4-6): one writer per run folder or trace, every
numeric flag bounded by its meaning, a cluster address checked with a timeout, traces read in
bounded memory (the chunked reader held to the plain one), a full disk during a trace, a
closed or full standard output, and no MUJOCO_LOG.TXT in the user's folder."""

from __future__ import annotations

import argparse
import errno
import math
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from evolve.cli import build_parser, main
from sim2real.arg_types import cluster_address
from sim2real.errors import ConfigError, UsageError
from sim2real.hardware import trace as trace_module
from sim2real.hardware import trace_rows
from sim2real.hardware.trace import Trace, TraceCut, TraceWriter, sidecar_path
from sim2real.run_lock import RunFolderBusy, RunLock
from tests.test_cli_errors import assert_usage_error, biped

ROOT = Path(__file__).resolve().parent.parent
WALKER = ROOT / "configs" / "controllers" / "xl430_biped_no_gyro.json"
FIXTURE = ROOT / "tests" / "data" / "traces" / "mock_run_24747d4.csv"
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


# -- one writer per output -------------------------------------------------------------------
def _holder(target: Path, output: bool = False) -> subprocess.Popen:
    """A process holding the lock on ``target`` (a folder, or a named output) until killed."""
    take = (f"RunLock.acquire_output({str(target)!r}, what='biped excite', flag='--trace')" if output
            else f"RunLock.acquire({str(target)!r}, create=True)")
    holder = subprocess.Popen([sys.executable, "-c", f"import time; from sim2real.run_lock import RunLock; lock = {take}; "
                               "print('held', flush=True); time.sleep(120)"], stdout=subprocess.PIPE, text=True, env=ENV)
    assert holder.stdout.readline().strip() == "held"
    return holder


# Each command that writes a folder or a named output, with small settings, and the target it locks.
LOCKED = [
    ("polish", lambda t: ["polish", WALKER, "--out", t / "out", "--updates", "1", "--popsize", "2", "--robots", "1",
                          "--validation", "1", "--test", "1"], "out", False),
    ("train", lambda t: ["train", "xl430_biped", "--out", t / "out"], "out", False),
    ("adapt", lambda t: ["adapt", WALKER, "--reality", "nominal", "--out", t / "out", "--generations", "1"], "out", False),
    ("quickstart", lambda t: ["quickstart", "--out", t / "out", "--generations", "1", "--no-video"], "out", False),
    ("excite", lambda t: ["excite", "--joints", "knee", "--chirp-s", "3", "--steps", "2", "--trace", t / "e.csv"],
     "e.csv", True),
    ("dry-run", lambda t: ["dry-run", WALKER, "--duration", "0.5", "--trace", t / "e.csv"], "e.csv", True),
    ("run", lambda t: ["run", WALKER, "--bus", "mock", "--duration", "0.5", "--trace", t / "e.csv"], "e.csv", True),
    ("sysid --report", lambda t: ["sysid", FIXTURE, "--report", t / "out", "--max-iters", "1"], "out", False),
]


@pytest.mark.parametrize("name, argv, target, output", LOCKED, ids=[c[0] for c in LOCKED])
def test_a_second_writer_of_a_folder_or_trace_is_refused_at_once_naming_it_and_the_holder(
        name, argv, target, output, tmp_path, capsys):
    holder = _holder(tmp_path / target, output)
    try:
        (tmp_path / "out").mkdir(exist_ok=True)
        before = sorted(p.name for p in tmp_path.rglob("*"))
        started = time.monotonic()
        result = biped(argv(tmp_path), capsys)
        assert time.monotonic() - started < 60  # at once: no simulation, no robot moved
        assert_usage_error(result, str(tmp_path / target), f"process id {holder.pid}")
        assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing of the holder's touched
    finally:
        holder.kill()
        holder.wait()


def test_two_polishes_into_one_folder_the_second_refused_the_first_unharmed(tmp_path):
    out = tmp_path / "p"
    argv = [sys.executable, "-m", "evolve.cli", "polish", str(WALKER), "--out", str(out), "--updates", "2",
            "--popsize", "4", "--robots", "2", "--every", "1", "--validation", "3", "--test", "3", "--json"]
    first = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    try:
        deadline = time.monotonic() + 120
        while not (out / ".lock").exists() and first.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        assert (out / ".lock").exists(), "the first polish took no lock within 2 min"
        # held still while the second starts: a short polish could otherwise end and release the
        # lock before a slow machine's second process reached its check
        first.send_signal(signal.SIGSTOP)
        try:
            second = subprocess.run(argv, capture_output=True, text=True, env=ENV, timeout=120)
        finally:
            first.send_signal(signal.SIGCONT)
        assert second.returncode == 2, second.stderr
        assert second.stderr.strip() == (f"biped: error: {out}: another biped polish is working in this folder (process "
                                         f"id {first.pid}); two in one folder would overwrite each other's files. Wait "
                                         "for it to end (or stop it), or give another --out")
        stdout, stderr = first.communicate(timeout=300)
    finally:
        first.kill()
        first.wait()
    assert first.returncode == 0, stderr
    assert (out / "polished.json").exists() and (out / "result.json").exists()
    assert not (out / ".lock").exists()  # removed on release


def test_a_stale_lock_of_a_dead_process_does_not_block_and_release_cleans_up(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / ".lock").write_text(dead.stdout)  # the pid of a process that is gone
    (tmp_path / ".t.csv.lock").write_text(dead.stdout)
    with RunLock.acquire(tmp_path / "run", what="biped polish") as lock:
        assert (tmp_path / "run" / ".lock").read_text() == f"{os.getpid()}\n" and lock.held
    with RunLock.acquire_output(tmp_path / "t.csv", what="biped excite", flag="--trace"):
        with pytest.raises(RunFolderBusy, match=rf"{tmp_path / 't.csv'}: another biped excite .*process id {os.getpid()}"):
            RunLock.acquire_output(tmp_path / "t.csv", what="biped excite", flag="--trace")
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["run"]  # lock files removed on release
    with RunLock.acquire(tmp_path / "new" / "deep", create=True):
        assert (tmp_path / "new" / "deep").is_dir()
    assert not (tmp_path / "new").exists()  # made by the lock, left empty: removed


def test_a_lock_released_while_another_opened_it_is_not_held_twice(tmp_path, monkeypatch):
    """Release removes the lock file: a process that opened the old one before must lock the new."""
    import sim2real.run_lock as run_lock

    first = RunLock.acquire(tmp_path)

    calls = []
    original = run_lock.fcntl.flock

    def flock_after_release(fd, op):
        if not calls:  # the moment between our open and our flock: the holder lets go and removes it
            calls.append(fd)
            first.release()
        return original(fd, op)

    monkeypatch.setattr(run_lock.fcntl, "flock", flock_after_release)
    second = RunLock.acquire(tmp_path)
    monkeypatch.setattr(run_lock.fcntl, "flock", original)
    assert len(calls) == 1
    with pytest.raises(RunFolderBusy):  # the second holds the lock file that is there now
        RunLock.acquire(tmp_path)
    second.release()


# -- numbers bounded by their meaning ----------------------------------------------------------
NOT_NUMBERS = {"Path", "output_file", "output_dir", "robot_name", "reality_name", "_servo_model", "heading_schedule",
               "reach_target", "cluster_address", "_servo_choice", "config_override"}
DISCRETE = {"baud_rate", "cpu_index"}  # numbers from a list: a rate a profile lists, a CPU this process may use


def _flags(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ("biped",)):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _flags(sub, (*prefix, name))
        elif action.type is not None:
            yield " ".join(prefix), parser, action


NUMERIC = [(command, parser, action) for command, parser, action in _flags(build_parser())
           if getattr(action.type, "__name__", str(action.type)) not in NOT_NUMBERS]


def test_every_typed_flag_is_known_as_a_number_or_not():
    names = {getattr(a.type, "__name__", str(a.type)) for _, _, a in _flags(build_parser())}
    assert len(NUMERIC) >= 40
    assert names - NOT_NUMBERS, names  # the numbers are there


def _value(parser, action, text):
    return parser._get_value(action, text)  # argparse's own conversion, its error naming the flag


@pytest.mark.parametrize("command, parser, action", NUMERIC,
                         ids=[f"{c} {a.option_strings[-1] if a.option_strings else a.dest}" for c, _, a in NUMERIC])
def test_every_numeric_flag_is_bounded_by_its_meaning(command, parser, action):
    name = getattr(action.type, "__name__", str(action.type))
    flag = "/".join(action.option_strings) or action.dest
    for hostile in ("1e308", "-1e308", "nan", "inf", "-inf", "9" * 400, "1e400", "", "0x10"):
        with pytest.raises(argparse.ArgumentError) as refused:
            _value(parser, action, hostile)
        assert flag.split("/")[0] in str(refused.value) or action.dest in str(refused.value), str(refused.value)
    if name in DISCRETE:
        return
    bounds = getattr(action.type, "bounds", None)
    assert bounds is not None, f"{command} {flag}: a numeric flag without bounds ({name})"
    low, high = bounds
    assert math.isfinite(low) and math.isfinite(high) and low < high
    whole = isinstance(low, int) and isinstance(high, int)
    step = 1 if whole else max(1e-9, abs(high) * 1e-6)
    _value(parser, action, str(high))
    with pytest.raises(argparse.ArgumentError):
        _value(parser, action, str(high + step))
    with pytest.raises(argparse.ArgumentError):
        _value(parser, action, str(low - step))
    if getattr(action.type, "low_open", False):
        with pytest.raises(argparse.ArgumentError):
            _value(parser, action, str(low))
        _value(parser, action, str(low + step))
    else:
        _value(parser, action, str(low))


@pytest.mark.parametrize("argv, flag", [
    (["render", "--settle", "1e308"], "--settle"),
    (["excite", "--chirp-s", "1e308", "--trace", "x.csv"], "--chirp-s"),
    (["excite", "--tick-ms", "0.001", "--trace", "x.csv"], "--tick-ms"),
    (["render", "--width", "100000"], "--width"),
    (["run", WALKER, "--heading", "1e308:5"], "--heading"),
    (["run", WALKER, "--reach-target", "1e308,0,0"], "--reach-target"),
], ids=["settle", "chirp-s", "tick-ms", "width", "heading time", "reach target"])
def test_the_issues_numbers_are_refused_by_argparse_naming_the_flag(argv, flag, capsys):
    assert_usage_error(biped(argv, capsys), flag)


# -- a cluster address, checked with a timeout -------------------------------------------------
@pytest.mark.parametrize("address, problem", [
    ("nonsense:99999", "port"), ("nonsense:0", "port"), ("nonsense", "HOST:PORT"), (":6379", "HOST:PORT"),
    ("a b:6379", "host name"), ("[::g]:6379", "IPv6"), ("host:http", "port"), ("-x:1", "host name"),
])
def test_a_cluster_address_of_the_wrong_form_is_refused_at_parse_time(address, problem, capsys):
    with pytest.raises(argparse.ArgumentTypeError, match=problem):
        cluster_address(address)
    assert_usage_error(biped(["evolve", "--backend", "ray", "--address", address], capsys), "--address")
    assert cluster_address("10.0.0.1:6379") == "10.0.0.1:6379" and cluster_address("[::1]:1") == "[::1]:1"


def _server(reply: bytes | None):
    """A local TCP server that answers each connection with ``reply`` (None: says nothing)."""
    listener = socket.create_server(("127.0.0.1", 0))
    accepted = []

    def serve():
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            accepted.append(conn)
            if reply is not None:
                conn.recv(64)
                conn.sendall(reply)

    threading.Thread(target=serve, daemon=True).start()
    return listener, accepted


def test_an_unreachable_cluster_is_refused_within_its_timeout():
    pytest.importorskip("ray")
    from evolve.ray_backend import check_reachable

    free = socket.create_server(("127.0.0.1", 0))
    port = free.getsockname()[1]
    free.close()  # nothing listens there now
    with pytest.raises(UsageError, match=f"--address 127.0.0.1:{port}: cannot connect"):
        check_reachable(f"127.0.0.1:{port}")
    with pytest.raises(UsageError, match="cannot resolve the host"):
        check_reachable("no-such-host.invalid:6379")
    silent, _ = _server(None)
    started = time.monotonic()
    with pytest.raises(UsageError, match=r"no answer within 0.5 s"):
        check_reachable(f"127.0.0.1:{silent.getsockname()[1]}", timeout_s=0.5)
    assert time.monotonic() - started < 10
    web, _ = _server(b"HTTP/1.1 400 Bad Request\r\n\r\n")
    with pytest.raises(UsageError, match="not a Ray cluster's head"):
        check_reachable(f"127.0.0.1:{web.getsockname()[1]}")
    grpc_like, _ = _server(bytes([0, 0, 0, 4, 0, 0, 0, 0, 0]))  # an HTTP/2 server's SETTINGS frame
    check_reachable(f"127.0.0.1:{grpc_like.getsockname()[1]}")
    for listener in (silent, web, grpc_like):
        listener.close()


def test_biped_evolve_refuses_an_unreachable_cluster_before_anything_runs(tmp_path, capsys):
    pytest.importorskip("ray")
    free = socket.create_server(("127.0.0.1", 0))
    port = free.getsockname()[1]
    free.close()
    result = biped(["evolve", "--backend", "ray", "--address", f"127.0.0.1:{port}", "--out", tmp_path / "r"], capsys)
    assert_usage_error(result, f"--address 127.0.0.1:{port}", "cannot connect")
    assert not (tmp_path / "r").exists()


# -- traces in bounded memory: the chunked reader held to the plain one -------------------------
HEADER = "time_s,tick,a_goal_rad,a_present_rad"


def _rows(n: int, start: int = 0) -> list[str]:
    return [f"{k * 0.01:.6f},{k},{math.sin(k) * 0.5:.6f},{math.cos(k) * 0.5:.6f}" for k in range(start, start + n)]


TRACES = {
    "plain": HEADER + "\n" + "\n".join(_rows(300)) + "\n",
    "crlf": HEADER + "\r\n" + "\r\n".join(_rows(300)) + "\r\n",
    "cut without an end of line": HEADER + "\n" + "\n".join(_rows(300)) + "\n0.5,",
    "cut with too few fields": HEADER + "\n" + "\n".join(_rows(300)) + "\n3.000000,300\n",
    "blank lines at the end": HEADER + "\n" + "\n".join(_rows(300)) + "\n\n\n\n",
    "last row whole, no end of line": HEADER + "\n" + "\n".join(_rows(300)),
    "quoted cells": HEADER + "\n" + "\n".join(_rows(100)) + '\n"1.000000","100","0.1","0.2"\n' + "\n".join(_rows(5, 101)) + "\n",
    "spaces around numbers": HEADER + "\n" + "\n".join(" " + r.replace(",", " , ") for r in _rows(200)) + "\n",
    "a blank line inside": HEADER + "\n" + "\n".join(_rows(150)) + "\n\n" + "\n".join(_rows(150, 150)) + "\n",
    "a word inside": HEADER + "\n" + "\n".join(_rows(200)) + "\n2.000000,200,walk,0.1\n" + "\n".join(_rows(5, 201)) + "\n",
    "nan inside": HEADER + "\n" + "\n".join(_rows(200)) + "\n2.000000,200,nan,0.1\n",
    "a long row inside": HEADER + "\n" + "\n".join(_rows(200)) + "\n2.000000,200,0.1,0.1,0.2\n" + "\n".join(_rows(3, 201)) + "\n",
    "header only": HEADER + "\n",
    "empty": "\n\n",
    "duplicate header": "time_s,time_s\n0,1\n",
    "no time column": "tick,a\n0,1\n",
    "binary": HEADER + "\n" + "\n".join(_rows(10)) + "\n\0\0\n",
    "form feed line breaks": HEADER + "\n" + "\n".join(_rows(50)) + "\n" + "\x0c".join(_rows(20, 50)) + "\n",
}


def _outcome(read, path: Path):
    try:
        trace = Trace.read(path, reader=read)
    except ConfigError as exc:
        return "refused", str(exc)
    return trace.times.tolist(), trace.data.tolist(), [c.name for c in trace.channels], list(trace.notes)


@pytest.mark.parametrize("chunk", [37, 1000, 4 << 20], ids=["tiny chunks", "small chunks", "one chunk"])
@pytest.mark.parametrize("name", list(TRACES))
def test_the_chunked_reader_reads_what_the_plain_one_reads(name, chunk, tmp_path, monkeypatch):
    path = tmp_path / "t.csv"
    path.write_bytes(TRACES[name].encode())
    monkeypatch.setattr(trace_rows, "CHUNK_BYTES", chunk)
    expected = _outcome(trace_rows.read_rows_plain, path)
    assert _outcome(trace_rows.read_rows, path) == expected
    if name == "plain":
        assert expected[0] != "refused" and len(expected[0]) == 300


def test_the_shipped_fixture_reads_alike_and_a_trace_past_the_limit_is_refused_unread(tmp_path, monkeypatch):
    assert _outcome(trace_rows.read_rows, FIXTURE) == _outcome(trace_rows.read_rows_plain, FIXTURE)
    big = tmp_path / "big.csv"
    big.write_text(HEADER + "\n" + "\n".join(_rows(1000)) + "\n")
    monkeypatch.setattr(trace_rows, "MAX_TRACE_BYTES", 10_000)
    with pytest.raises(ConfigError, match=r"big.csv: .*too large for a trace \(at most .*10000 bytes"):
        Trace.read(big)


# -- a full disk during a trace ----------------------------------------------------------------
def _full_after(monkeypatch, allowed: int) -> None:
    """The disk takes ``allowed`` more bytes of the trace, then refuses (ENOSPC), as a full one does."""
    left = [allowed]
    real_write = os.write

    def write(fd, data):
        if left[0] <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        n = real_write(fd, bytes(data[:left[0]]))
        left[0] -= n
        return n

    monkeypatch.setattr(trace_module.os, "write", write)


def _write_rows(writer: TraceWriter, n: int, start: int = 0) -> None:
    for k in range(start, start + n):
        writer.write(k * 0.034, k, np.full(11, 0.1), np.full(11, 0.1), np.array([1, 0]), np.array([0, 0, 1.0]),
                     1e-4, 1e-3, False)


def test_a_trace_cut_by_a_full_disk_ends_at_its_last_whole_row_and_says_what_it_kept(tmp_path, monkeypatch):
    from sim2real.robot import load_robot

    joints = load_robot().joint_names
    path = tmp_path / "run.csv"
    writer = TraceWriter(path, joints, {"robot": "xl430_biped", "tick_s": 0.034})
    monkeypatch.setattr(trace_module, "FLUSH_EVERY_S", 0.0)
    _write_rows(writer, 40)
    _full_after(monkeypatch, 1000)  # a few rows and a part of one more
    with pytest.raises(TraceCut) as cut:
        _write_rows(writer, 20, start=40)
    writer.close()  # after a cut: nothing more to write, no second error
    kept = Trace.read(path)
    assert not kept.notes  # no row cut short: the file ends at a whole row
    assert len(kept) == 40 + 1000 // len(path.read_bytes().splitlines()[1] + b"\r\n") == writer.rows
    message = str(cut.value)
    assert "[Errno" not in message and message.startswith("No space left on device: ")
    assert f"kept {writer.rows} rows ({kept.times[-1]:.1f} s) in {path}, which ends at its last whole row" in message


def test_a_trace_the_disk_refuses_from_the_start_leaves_no_file(tmp_path, monkeypatch):
    path = tmp_path / "excite.csv"
    _full_after(monkeypatch, 0)
    with pytest.raises(OSError, match="No space left"):
        TraceWriter(path, ["knee"], {"robot": "xl430_biped"})
    assert list(tmp_path.iterdir()) == []  # neither the trace nor its sidecar
    monkeypatch.undo()
    writer = TraceWriter(path, ["knee"], {"robot": "xl430_biped"})
    writer.close()  # no row: nothing of use
    assert list(tmp_path.iterdir()) == []


def test_biped_run_on_a_full_disk_says_what_the_trace_kept(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(trace_module, "FLUSH_EVERY_S", 0.0)
    _full_after(monkeypatch, 3000)  # the header and some rows
    trace = tmp_path / "run.csv"
    result = biped(["run", WALKER, "--bus", "mock", "--duration", "2", "--trace", trace, "--no-realtime"], capsys)
    assert result.code == 1, result.err
    assert "[Errno" not in result.err, result.err
    assert f"rows (" in result.err and f"in {trace}, which ends at its last whole row" in result.err
    monkeypatch.undo()
    assert not Trace.read(trace).notes


# -- standard output ---------------------------------------------------------------------------
def test_standard_output_to_a_full_device_or_a_closed_pipe_is_one_line_and_fails(tmp_path):
    argv = [sys.executable, "-m", "evolve.cli", "robot", "show"]
    with open("/dev/full", "w") as full:
        done = subprocess.run(argv, stdout=full, stderr=subprocess.PIPE, text=True, env=ENV, cwd=tmp_path)
    assert done.returncode == 1 and done.stderr.strip().splitlines() == [
        "biped: error: cannot write /dev/full: No space left on device (is the disk full?); the output is cut short"]
    read, write = os.pipe()
    os.close(read)  # the reader is gone before a byte is written: as `| head` ends
    try:
        done = subprocess.run(argv, stdout=write, stderr=subprocess.PIPE, text=True, env=ENV, cwd=tmp_path)
    finally:
        os.close(write)
    assert done.returncode == 1 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert done.stderr.startswith("biped: error: the standard output was closed before the output ended")


# -- MuJoCo's log ------------------------------------------------------------------------------
UNSTABLE = """
import math, numpy as np
from sim2real.robot import load_robot
from sim2real.simulation.transfer.compare import _simulate
from sim2real.simulation.model.builder import SimulationUnstable
from sim2real.simulation.reality.file import Reality
from sim2real.simulation.reality.randomize import perturbed_model
robot = load_robot()
model, _ = perturbed_model(robot, Reality("blown-up", "", {"armature_scale": (math.inf, math.inf)}))
try:
    _simulate(robot, np.arange(5) * 0.034, np.tile([j.home_rad for j in robot.joints], (5, 1)), None, model)
except SimulationUnstable as exc:
    print("unstable:", exc)
"""


def test_a_mujoco_warning_leaves_no_log_file_in_the_working_folder(tmp_path):
    done = subprocess.run([sys.executable, "-c", UNSTABLE], capture_output=True, text=True, env=ENV, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "unstable: the simulation went numerically unstable" in done.stdout  # MuJoCo warned
    assert "WARNING" in done.stdout + done.stderr  # its own printed line stays
    assert list(tmp_path.iterdir()) == []  # but no MUJOCO_LOG.TXT
