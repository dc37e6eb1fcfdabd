"""Hostile files and folders (issue 31, sections 3 and 4): what a user can hand ``biped`` in
place of a file, and what the disk can do to its outputs.

* inputs: every file argument of every command x {named pipe, directory, character device,
  missing, unreadable, empty, binary}: refused at once (a FIFO used to hang ``biped run``),
  exit 2, one line naming the file;
* outputs: every output flag x {full disk, a directory in the way, a missing folder, a FIFO
  in the way}: a full disk ends in one line ``biped: error: cannot write FILE: No space left
  on device`` and exit 1, with no file left behind (``robot mjcf`` left a 0-byte file); a
  real full disk is a small tmpfs (root only; skipped elsewhere), and everywhere the disk
  refuses the final flush (``fsync``) instead;
* one run per folder: a second ``biped evolve`` or ``--resume`` into a folder another
  process works in is refused naming that process; a killed holder frees it;
* values that pass the format's checks but mean nothing on the robot (hold angles, the
  tick) or in a trace (angles, time).

Nothing here runs an evolution or a bus for more than a few seconds; every in-process case
is under an alarm, so that a regression that blocks fails instead of hanging the suite.
"""

import csv
import errno
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from hang_guard import fails_after

import sim2real.atomic_json as atomic_json
import sim2real.hardware.trace as trace_module
from evolve.locomotion.evaluator import neat_layout
from evolve.locomotion.export import controller_from_genome
from evolve.locomotion.task import TaskConfig
from evolve.neat import Genome, NeatConfig, Population
from sim2real.run_lock import RunFolderBusy, RunLock
from sim2real.controller.robot_checks import tick_bounds
from sim2real.controller.file import Controller
from sim2real.controller.symmetry import symmetric_layout
from sim2real.errors import ConfigError, UsageError
from sim2real.hardware.trace import Trace, TraceWriter
from sim2real.robot import load_robot
from evolve.cli import main
from tests.test_cli_errors import Result, assert_usage_error, biped, write_trace
from tests.unprivileged import as_unprivileged, captured, open_folder

ROBOT = load_robot()
AS_ROOT = os.geteuid() == 0
SMALL_RUN = {  # a run folder's config: generations of 10 robots for 1 s each
    "robot": "xl430_biped", "seed": 3, "generations": 100_000, "threads": 1, "checkpoint_every": 0,
    "task": {"episode_s": 1.0, "harness_generations": 2, "harness_fade_generations": 1},
    "neat": {"population_size": 10, "target_species": 3, "compat_threshold": 0.5},
}


@pytest.fixture(autouse=True)
def no_hang():
    """An in-process command that blocks (a FIFO opened for reading) fails after 30 s."""
    with fails_after(30):
        yield


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("good")


@pytest.fixture(scope="module")
def controller(folder) -> Path:
    """A standing controller (no connections) for the default robot, 1 s episodes."""
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    path = folder / "stand.json"
    controller_from_genome(Genome(0, neat_layout(layout)), ROBOT, layout, TaskConfig(episode_s=1.0), 1.0,
                           {"seed": 0}).save(path)
    return path


@pytest.fixture(scope="module")
def trace(folder) -> Path:
    return write_trace(folder / "t.csv")


@pytest.fixture(scope="module")
def run_dir(folder, controller) -> Path:
    """A run folder as a generation leaves it: config.yaml, checkpoint, stats.csv, controller.json."""
    from evolve.config import parse_evolve_config

    run = folder / "run"
    run.mkdir()
    config = parse_evolve_config(SMALL_RUN, "small")
    (run / "config.yaml").write_text(config.to_yaml())
    layout = symmetric_layout(ROBOT, ROBOT.control_sets["walk"])
    Population(NeatConfig(population_size=10, target_species=3), neat_layout(layout), seed=1).save(
        run / "checkpoint.json.gz")
    (run / "stats.csv").write_text("generation\n")
    (run / "controller.json").write_bytes(controller.read_bytes())
    return run


# -- inputs -------------------------------------------------------------------------------------
KINDS = ["fifo", "directory", "device", "missing", "unreadable", "empty", "binary"]


def make(kind: str, path: Path, good: Path | None) -> Path:
    """``path`` made into a hostile ``kind`` of file (``good``: valid content for 'unreadable')."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists() or path.is_symlink():
        if path.is_dir() and not path.is_symlink():
            path.rmdir()
        else:
            path.unlink()
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "directory":
        path.mkdir()
    elif kind == "device":
        path.symlink_to("/dev/zero")  # named like the file a command wants: the suffix still says what it is
    elif kind == "unreadable":
        path.write_bytes(good.read_bytes() if good else b"x: 1\n")
        path.chmod(0)
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "binary":
        path.write_bytes(bytes(range(256)) * 8)
    return path


# (id, argv with {f} the hostile file, its name, the kinds it must refuse, valid content for
# 'unreadable').  Empty YAML files of reality, evolution and fault kinds are section 2's
# (today an empty one is taken as "nothing": nominal, every default, no faults).
CONTROLLER_KINDS = KINDS
YAML_KINDS = [k for k in KINDS if k != "empty"]
INPUTS = [
    ("run CONTROLLER", ["run", "{f}", "--bus", "mock"], "c.json", CONTROLLER_KINDS, "controller"),
    ("dry-run CONTROLLER", ["dry-run", "{f}"], "c.json", CONTROLLER_KINDS, "controller"),
    ("eval CONTROLLER", ["eval", "{f}"], "c.json", CONTROLLER_KINDS, "controller"),
    ("render CONTROLLER", ["render", "{f}", "-o", "{tmp}/w.gif"], "c.json", CONTROLLER_KINDS, "controller"),
    ("render --strip", ["render", "--strip", "{f}", "-o", "{tmp}/s.png"], "c.json", CONTROLLER_KINDS, "controller"),
    ("plot gait CONTROLLER", ["plot", "gait", "{f}", "-o", "{tmp}/g.png"], "c.json", CONTROLLER_KINDS, "controller"),
    ("plot network", ["plot", "network", "{f}", "-o", "{tmp}/n.svg"], "c.json", CONTROLLER_KINDS, "controller"),
    ("compare --controller", ["compare", "{trace}", "--controller", "{f}"], "c.json", CONTROLLER_KINDS,
     "controller"),
    ("export RUN_DIR", ["export", "{dir}", "-o", "{tmp}/c.json"], "run/controller.json", CONTROLLER_KINDS,
     "controller"),
    ("compare TRACE", ["compare", "{f}"], "t.csv", KINDS, "trace"),
    ("plot gait --trace", ["plot", "gait", "--trace", "{f}", "-o", "{tmp}/g.png"], "t.csv", KINDS, "trace"),
    ("sysid TRACE", ["sysid", "{f}"], "t.csv", KINDS, "trace"),
    ("robot show ROBOT", ["robot", "show", "{f}"], "r.yaml", KINDS, None),
    ("robot mjcf ROBOT", ["robot", "mjcf", "{f}", "-o", "{tmp}/r.xml"], "r.yaml", KINDS, None),
    ("render ROBOT", ["render", "{f}", "-o", "{tmp}/r.png"], "r.yaml", KINDS, None),
    ("eval --robot", ["eval", "{c}", "--robot", "{f}"], "r.yaml", KINDS, None),
    ("run --robot", ["run", "{c}", "--robot", "{f}", "--bus", "mock"], "r.yaml", KINDS, None),
    ("simbus --robot", ["simbus", "--robot", "{f}"], "r.yaml", KINDS, None),
    ("excite --robot", ["excite", "--robot", "{f}", "--trace", "{tmp}/e.csv"], "r.yaml", KINDS, None),
    ("robot preset FILE:preset", ["robot", "show", "{f}:male_50"], "r.yaml", KINDS, None),
    ("dry-run --reality", ["dry-run", "{c}", "--reality", "{f}"], "re.yaml", YAML_KINDS, None),
    ("eval --reality", ["eval", "{c}", "--reality", "{f}"], "re.yaml", YAML_KINDS, None),
    ("eval --randomize", ["eval", "{c}", "--randomize", "{f}"], "re.yaml", YAML_KINDS, None),
    ("compare --reality", ["compare", "{trace}", "--reality", "{f}"], "re.yaml", YAML_KINDS, None),
    ("simbus --reality", ["simbus", "--reality", "{f}"], "re.yaml", YAML_KINDS, None),
    ("excite --reality", ["excite", "--reality", "{f}", "--trace", "{tmp}/e.csv"], "re.yaml", YAML_KINDS, None),
    ("plot gait --reality", ["plot", "gait", "{c}", "--reality", "{f}", "-o", "{tmp}/g.png"], "re.yaml",
     YAML_KINDS, None),
    ("quickstart --reality", ["quickstart", "--reality", "{f}", "--out", "{tmp}/q"], "re.yaml", YAML_KINDS, None),
    ("evolve CONFIG", ["evolve", "{f}", "--out", "{tmp}/run"], "e.yaml", YAML_KINDS, None),
    ("dry-run --faults", ["dry-run", "{c}", "--faults", "{f}"], "f.yaml", YAML_KINDS, None),
    ("simbus --faults", ["simbus", "--faults", "{f}"], "f.yaml", YAML_KINDS, None),
    ("evolve --resume: config.yaml", ["evolve", "--resume", "--out", "{dir}"], "run/config.yaml",
     [k for k in YAML_KINDS if k != "missing"], None),
    ("evolve --resume: checkpoint", ["evolve", "--resume", "--out", "{dir}"], "run/checkpoint.json.gz", KINDS,
     "checkpoint"),
]
CASES = [pytest.param(argv, name, kind, good, id=f"{label} x {kind}")
         for label, argv, name, kinds, good in INPUTS for kind in kinds]


@pytest.mark.parametrize("argv, name, kind, good", CASES)
def test_a_file_argument_that_is_not_a_readable_regular_file_is_refused_at_once(argv, name, kind, good, tmp_path,
                                                                                  controller, trace, run_dir, capsys):
    if kind == "unreadable" and AS_ROOT:  # root reads a file whatever its mode: the command runs as nobody
        with open_folder() as folder:
            refused_at_once(argv, name, kind, good, folder, *copied_to(folder, controller, trace, run_dir),
                            run=lambda args: Result(*as_unprivileged(lambda: captured(lambda: main(args)))))
        return
    refused_at_once(argv, name, kind, good, tmp_path, controller, trace, run_dir,
                    run=lambda args: biped(args, capsys))


def copied_to(folder: Path, *paths: Path) -> list[Path]:
    """Copies of the good files and folders in ``folder`` (one that ``nobody`` can read)."""
    copies = []
    for path in paths:
        copy = folder / "good" / path.name
        copy.parent.mkdir(exist_ok=True)
        if path.is_dir():
            copy.mkdir()
            for f in path.iterdir():
                (copy / f.name).write_bytes(f.read_bytes())
        else:
            copy.write_bytes(path.read_bytes())
        copies.append(copy)
    for path in folder.rglob("*"):
        path.chmod(0o755 if path.is_dir() else 0o644)
    return copies


def refused_at_once(argv, name, kind, good, tmp_path: Path, controller: Path, trace: Path, run_dir: Path,
                    run) -> None:
    """``biped argv`` (by ``run``) with the hostile file refuses it at once, naming it."""
    if name.startswith("run/"):  # a file inside a run folder: a copy of the good one, one file spoiled
        (tmp_path / "run").mkdir()
        (tmp_path / "run").chmod(0o777)  # run as nobody, a command may take the folder's lock before it reads
        for f in run_dir.iterdir():
            (tmp_path / "run" / f.name).write_bytes(f.read_bytes())
            (tmp_path / "run" / f.name).chmod(0o644)
    goods = {"controller": controller, "trace": trace, "checkpoint": run_dir / "checkpoint.json.gz"}
    path = make(kind, tmp_path / name, goods.get(good))
    argv = [str(a).format(f=path, c=controller, trace=trace, tmp=tmp_path, dir=path.parent) for a in argv]
    start = time.monotonic()
    result = run(argv)
    assert_usage_error(result, str(path.parent) if name.startswith("run/") else str(path))
    assert time.monotonic() - start < 10
    assert not (tmp_path / "q").exists()  # nothing started
    if not name.startswith("run/"):
        assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("kind", ["fifo", "device", "directory", "missing", "binary"])
@pytest.mark.parametrize("name", ["c.json", "r.yaml"], ids=["view CONTROLLER", "view ROBOT"])
def test_view_refuses_the_file_before_it_opens_a_window(name, kind, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("DISPLAY", ":99")  # past the display check: the file is refused before any window
    path = make(kind, tmp_path / name, None)
    assert_usage_error(biped(["view", path], capsys), str(path))


def test_a_trace_whose_sidecar_is_a_fifo_is_refused(tmp_path, capsys):
    path = write_trace(tmp_path / "t.csv")
    make("fifo", path.with_suffix(".json"), None)
    assert_usage_error(biped(["compare", path], capsys), str(path.with_suffix(".json")), "named pipe")


def test_a_sidecar_of_unexpected_shape_is_refused_or_ignored_never_a_crash(tmp_path, capsys):
    path = write_trace(tmp_path / "t.csv")
    sidecar = path.with_suffix(".json")
    meta = json.loads(sidecar.read_text())
    sidecar.write_text(json.dumps({**meta, "excitation": "hung", "tick_s": "fast"}))
    result = biped(["compare", path, "--json"], capsys)
    assert result.code == 0, result.err
    assert json.loads(result.out)["suspended"] is False
    sidecar.write_text('{"robot": ' + "9" * 5000 + "}")  # past Python's digit limit
    assert_usage_error(biped(["compare", path], capsys), "t.json", "sidecar")


def test_a_robot_file_named_in_a_path_with_a_fifo_is_not_read(tmp_path):
    from sim2real.input_files import read_regular_bytes

    make("fifo", tmp_path / "pipe", None)
    (tmp_path / "link.yaml").symlink_to(tmp_path / "pipe")  # a link to a FIFO is a FIFO
    with pytest.raises(ConfigError, match="link.yaml: is a named pipe"):
        read_regular_bytes(tmp_path / "link.yaml")



def test_a_files_digest_is_its_bytes_and_a_fifo_or_a_copy_is_refused(tmp_path):
    import hashlib

    from sim2real.input_files import file_sha256, refuse_repeats

    walker = tmp_path / "walker.json"
    walker.write_bytes(b'{"format": "biped-controller"}\n' * 100_000)  # more than one chunk
    assert file_sha256(walker) == hashlib.sha256(walker.read_bytes()).hexdigest()
    make("fifo", tmp_path / "pipe", None)
    with pytest.raises(ConfigError, match="pipe: is a named pipe"):
        file_sha256(tmp_path / "pipe")  # refused, never waited on
    (tmp_path / "copy.json").write_bytes(walker.read_bytes())
    with pytest.raises(UsageError, match=r"copy.json: the same bytes as .*walker.json"):
        refuse_repeats([walker, tmp_path / "copy.json"], "walker")

# -- outputs --------------------------------------------------------------------------------------
def _mount_full(where: Path) -> bool:
    """A 64 KiB tmpfs at ``where``, filled to the last block: a real full disk (root only)."""
    where.mkdir()
    if not AS_ROOT:
        return False
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k,mode=1777", "tmpfs", str(where)],
                          capture_output=True)
    if done.returncode:
        return False
    fd = os.open(where / "filler", os.O_WRONLY | os.O_CREAT)
    try:
        while True:
            os.write(fd, b"\0" * 4096)
    except OSError as exc:
        assert exc.errno == errno.ENOSPC
    finally:
        os.close(fd)
    return True


@pytest.fixture(params=["tmpfs", "fsync refused"])
def full_disk(request, tmp_path, monkeypatch):
    """A folder on a disk that refuses to store any more: a real full tmpfs, or (anywhere)
    a disk whose final flush of an output fails with ENOSPC (as NFS and full ext4 can)."""
    where = tmp_path / "full"
    if request.param == "tmpfs":
        if not _mount_full(where):
            pytest.skip("cannot mount a tmpfs here (needs root)")
        yield where
        subprocess.run(["umount", "-l", str(where)], check=True)
    else:
        where.mkdir()

        def refuse(path):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        monkeypatch.setattr(atomic_json, "_fsync", refuse)
        yield where


class FakeFit:
    """What ``identify`` returns, without minutes of fitting: ``biped sysid -o`` writes it."""
    rmse_deg_before = {"right_knee": 2.0}
    rmse_deg_after = {"right_knee": 1.0}
    reality = {"kp_scale": 1.1}
    segments, iterations, seconds = 1, 1, 0.0
    parameters = {"XL430-W250-T/kp_scale": {"value": 1.1, "low": 1.0, "high": 1.2, "identifiable": True}}

    def summary(self):
        return {"reality": self.reality}


# (id, argv with {o} the output, its name)
OUTPUTS = [
    ("robot mjcf -o", ["robot", "mjcf", "-o", "{o}"], "robot.xml"),
    ("render ROBOT -o", ["render", "-o", "{o}", "--width", "64", "--height", "48", "--settle", "0"], "robot.png"),
    ("render CONTROLLER -o .gif", ["render", "{c}", "-o", "{o}", "--seconds", "0.1", "--width", "64",
                                  "--height", "48"], "walk.gif"),
    ("render CONTROLLER -o .mp4", ["render", "{c}", "-o", "{o}", "--seconds", "0.1", "--width", "64",
                                  "--height", "48"], "walk.mp4"),
    ("render --strip -o", ["render", "--strip", "{c}", "-o", "{o}", "--frames", "2", "--seconds", "0.1",
                           "--width", "64", "--height", "64"], "strip.png"),
    ("plot gait -o .png", ["plot", "gait", "--trace", "{trace}", "-o", "{o}"], "gait.png"),
    ("plot gait -o .pdf", ["plot", "gait", "--trace", "{trace}", "-o", "{o}"], "gait.pdf"),
    ("plot network -o .svg", ["plot", "network", "{c}", "-o", "{o}"], "net.svg"),
    ("export -o", ["export", "{run}", "-o", "{o}"], "c.json"),
    ("compare --plot", ["compare", "{trace}", "--plot", "{o}"], "compare.png"),
    ("sysid -o", ["sysid", "{trace}", "-o", "{o}", "--json"], "fitted.yaml"),
]


def _outputs(monkeypatch, argv, o, controller, trace, run_dir):
    import sim2real.simulation.identify

    monkeypatch.setattr(sim2real.simulation.identify, "identify", lambda *a, **k: FakeFit())
    return [a.format(o=o, c=controller, trace=trace, run=run_dir) for a in argv]


@pytest.mark.parametrize("argv, name", [pytest.param(a, n, id=i) for i, a, n in OUTPUTS])
def test_an_output_on_a_full_disk_is_one_line_naming_it_and_leaves_no_file(argv, name, full_disk, controller,
                                                                             trace, run_dir, monkeypatch, capsys):
    before = sorted(p.name for p in full_disk.iterdir())
    out = full_disk / name
    result = biped(_outputs(monkeypatch, argv, out, controller, trace, run_dir), capsys)
    assert result.code == 1, result.err
    assert "Traceback" not in result.err and "Exception ignored" not in result.err
    last = result.err.strip().splitlines()[-1]
    assert last.startswith(f"biped: error: cannot write {out}: No space left on device"), last
    assert sorted(p.name for p in full_disk.iterdir()) == before  # no partial file, no temporary file


@pytest.mark.parametrize("argv, name", [pytest.param(a, n, id=i) for i, a, n in OUTPUTS])
@pytest.mark.parametrize("obstacle", ["a directory in the way", "a missing folder", "a FIFO in the way"])
def test_an_output_path_that_cannot_be_written_is_refused_before_anything_runs(argv, name, obstacle, tmp_path,
                                                                              controller, trace, run_dir,
                                                                              monkeypatch, capsys):
    if obstacle == "a missing folder":
        out = tmp_path / "missing" / name
        named = str(tmp_path / "missing")
    else:
        out = tmp_path / name
        named = str(out)
        out.mkdir() if obstacle == "a directory in the way" else os.mkfifo(out)
    assert_usage_error(biped(_outputs(monkeypatch, argv, out, controller, trace, run_dir), capsys), named)
    assert not (tmp_path / "missing").exists()


@pytest.mark.parametrize("flag", [["run", "{c}", "--bus", "mock", "--trace"], ["dry-run", "{c}", "--trace"],
                                  ["excite", "--trace"]], ids=["run", "dry-run", "excite"])
def test_a_trace_into_a_fifo_or_a_device_is_refused_before_anything_runs(flag, tmp_path, controller, capsys):
    for target in (make("fifo", tmp_path / "t.csv", None), make("device", tmp_path / "d.csv", None)):
        assert_usage_error(biped([a.format(c=controller) for a in flag] + [target], capsys), "--trace", str(target))


class FullStream:
    """A standard output whose disk is full."""

    def write(self, text):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def flush(self):
        pass


@pytest.mark.parametrize("argv", [["robot", "mjcf"], ["robot", "show", "--json"], ["compare", "{trace}", "--json"]],
                         ids=["robot mjcf", "robot show", "compare"])
def test_standard_output_on_a_full_disk_is_named(argv, trace, monkeypatch, capsys):
    monkeypatch.setattr(sys, "stdout", FullStream())
    result = biped([a.format(trace=trace) for a in argv], capsys)
    assert result.code == 1
    assert result.err.strip().splitlines()[-1] == ("biped: error: cannot write the standard output: No space left on "
                                                   "device (is the disk full?); the output is cut short")


def test_standard_output_redirected_into_a_full_disk_names_the_file(tmp_path):
    where = tmp_path / "full"
    if not _mount_full(where):
        pytest.skip("cannot mount a tmpfs here (needs root)")
    try:
        with open(where / "robot.xml", "w") as out:  # `biped robot mjcf > robot.xml`: the shell makes the file
            done = subprocess.run([sys.executable, "-m", "evolve.cli", "robot", "mjcf"], stdout=out,
                                  stderr=subprocess.PIPE, text=True, timeout=120)
        assert done.returncode == 1 and "Traceback" not in done.stderr and "Exception ignored" not in done.stderr
        assert done.stderr.strip().splitlines()[-1].startswith(f"biped: error: cannot write {where / 'robot.xml'}: "
                                                               "No space left on device")
    finally:
        subprocess.run(["umount", "-l", str(where)], check=True)


def test_evolve_into_a_full_disk_names_the_file_and_starts_nothing(full_disk, tmp_path, capsys):
    config = tmp_path / "small.yaml"
    config.write_text(yaml.safe_dump({**SMALL_RUN, "generations": 2}))
    out = full_disk / "run"
    result = biped(["evolve", config, "--out", out, "--quiet"], capsys)
    assert result.code == 1, result.err
    assert result.err.strip().splitlines()[-1].startswith(f"biped: error: cannot write {out / 'config.yaml'}: "
                                                          "No space left on device")
    assert sorted(p.name for p in out.iterdir()) == []  # the lock file goes with the lock


def test_a_stats_row_the_disk_refuses_half_way_is_taken_back(tmp_path, monkeypatch):
    """A resume keeps the rows of generations below its checkpoint's: a row cut after '1' of
    '12' would be read as generation 1 and kept."""
    import evolve.run_stats
    from evolve.run_stats import StatsFile

    path = tmp_path / "stats.csv"
    path.write_text("generation,best_fitness\r\n0,1.5\r\n")
    before = path.read_bytes()
    written = []
    write = os.write  # the real one: os.write is patched below, and would call itself

    def half_then_full(fd, data):
        if written:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        written.append(bytes(data[:1]))
        return write(fd, bytes(data[:1]))

    monkeypatch.setattr(evolve.run_stats.os, "write", half_then_full)
    stats = StatsFile(path, ("generation", "best_fitness"))
    with pytest.raises(OSError, match=f"cannot write {path}: No space left on device.*generation 12"):
        stats.append({"generation": 12, "best_fitness": 2.0})
    assert written == [b"1"] and path.read_bytes() == before


def test_a_trace_writer_on_a_full_disk_raises_and_still_closes_its_file(tmp_path, monkeypatch):
    """The loop stops on the first refused row (main's deploy); its stop path then closes
    the writer, which must not leave an open file to fail again when collected, and the
    file ends at its last whole row."""
    where = tmp_path / "full"
    if not _mount_full(where):
        pytest.skip("cannot mount a tmpfs here (needs root)")
    try:
        (where / "filler").write_bytes(b"\0" * 40_000)  # room for the sidecar and a few rows
        writer = TraceWriter(where / "t.csv", ROBOT.joint_names, {"robot": ROBOT.name, "tick_s": 0.034})
        monkeypatch.setattr(trace_module, "FLUSH_EVERY_S", 0.0)  # as the one-second flush does, every row
        home = [j.home_rad for j in ROBOT.joints]
        with pytest.raises(OSError) as raised:
            for k in range(100_000):
                writer.write(k * 0.034, k, home, home, [1, 1], [0.0, 0.0, 1.0], 1e-4, 1e-3, False)
        assert raised.value.errno == errno.ENOSPC and f"kept {writer.rows} rows" in str(raised.value)
        assert writer._fd is None  # closed with the refusal
        writer.close()  # again: nothing left to do
        kept = Trace.read(where / "t.csv")  # what reached the disk reads back, to its last whole row
        assert len(kept) == writer.rows >= 1 and not kept.notes
    finally:
        subprocess.run(["umount", "-l", str(where)], check=True)


def test_a_run_tracing_into_a_disk_that_fills_stops_safely_and_names_the_trace(tmp_path, controller, capsys):
    where = tmp_path / "full"
    if not _mount_full(where):
        pytest.skip("cannot mount a tmpfs here (needs root)")
    try:
        os.truncate(where / "filler", 48_000)  # the sidecar fits, a few seconds of rows do not
        result = biped(["run", controller, "--bus", "mock", "--duration", "4", "--no-realtime",
                        "--trace", where / "t.csv"], capsys)
        assert result.code == 1, result.err
        assert "torque off, read back from all 11 servos" in result.err
        last = result.err.strip().splitlines()[-1]
        assert last.startswith("biped: error: the run stopped early:") and str(where / "t.csv") in last
        assert "No space left on device" in last
    finally:
        subprocess.run(["umount", "-l", str(where)], check=True)


def test_an_evolution_whose_disk_fills_mid_run_stops_resumable(tmp_path, capsys):
    """The disk fills between generations: the run stops naming the file it could not write,
    leaves no temporary file, and once there is room, --resume continues with every
    generation once in stats.csv."""
    where = tmp_path / "full"
    if not _mount_full(where):
        pytest.skip("cannot mount a tmpfs here (needs root)")
    try:
        (where / "filler").unlink()
        subprocess.run(["mount", "-o", "remount,size=4m", str(where)], check=True)
        config = tmp_path / "small.yaml"
        config.write_text(yaml.safe_dump({**SMALL_RUN, "generations": 30}))
        out = where / "run"

        def fill_after_two(run, row):
            if row["generation"] == 1:
                fd = os.open(where / "filler", os.O_WRONLY | os.O_CREAT)
                try:
                    while True:
                        os.write(fd, b"\0" * 4096)
                except OSError:
                    pass
                finally:
                    os.close(fd)
            return False

        from evolve.config import load_evolve_config
        from evolve.run import Run

        run = Run.create(load_evolve_config(config), out, log=lambda line: None)
        with pytest.raises(OSError) as raised:
            run.evolve(stop=fill_after_two)
        assert raised.value.errno == errno.ENOSPC and str(out) in str(raised.value)
        assert not [p for p in out.rglob("*") if ".tmp" in p.name]
        assert run.lock is None  # freed on the way out
        (where / "filler").unlink()
        done = biped(["evolve", "--resume", "--out", out, "--generations", "4", "--quiet"], capsys)
        assert done.code == 0, done.err
        with open(out / "stats.csv", newline="") as f:
            assert [int(r["generation"]) for r in csv.DictReader(f)] == [0, 1, 2, 3]
    finally:
        subprocess.run(["umount", "-l", str(where)], check=True)


# -- one run per folder ------------------------------------------------------------------------
def _start(argv: list, lock: Path) -> subprocess.Popen:
    """``biped argv`` in its own process, once it holds the folder's lock."""
    proc = subprocess.Popen([sys.executable, "-m", "evolve.cli", *map(str, argv)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if lock.exists() and lock.read_text().strip() == str(proc.pid):
            return proc
        time.sleep(0.05)
    proc.kill()
    raise AssertionError(f"the run did not start: {proc.communicate()[1]}")


def _generations(out: Path) -> list[int]:
    if not (out / "stats.csv").exists():
        return []
    with open(out / "stats.csv", newline="") as f:
        return [int(r["generation"]) for r in csv.DictReader(f)]


def test_two_runs_into_one_folder_the_second_is_refused_and_a_killed_one_frees_it(tmp_path, capsys):
    signal.alarm(300)
    config = tmp_path / "long.yaml"
    config.write_text(yaml.safe_dump(SMALL_RUN))
    out = tmp_path / "run"
    first = _start(["evolve", config, "--out", out, "--quiet"], out / ".lock")
    try:
        while len(_generations(out)) < 1:
            time.sleep(0.05)
        for argv in (["evolve", config, "--out", out, "--generations", "2", "--quiet"],
                     ["evolve", "--resume", "--out", out, "--generations", "50", "--quiet"]):
            refused = biped(argv, capsys)
            assert_usage_error(refused, str(out), f"process id {first.pid}")
            assert "another run is working in this folder" in refused.err
    finally:
        first.kill()  # SIGKILL: nothing of it can run, the kernel alone frees the lock
        first.wait()
    second = _start(["evolve", "--resume", "--out", out, "--generations", "100000", "--quiet"], out / ".lock")
    try:
        refused = biped(["evolve", "--resume", "--out", out, "--generations", "50", "--quiet"], capsys)
        assert_usage_error(refused, str(out), f"process id {second.pid}")
    finally:
        second.kill()
        second.wait()
    reached = len(_generations(out))
    done = biped(["evolve", "--resume", "--out", out, "--generations", str(reached + 1), "--quiet"], capsys)
    assert done.code == 0, done.err
    assert _generations(out) == list(range(reached + 1))  # every generation once


def test_the_lock_in_one_process_and_its_lock_file(tmp_path):
    lock = RunLock.acquire(tmp_path)
    assert (tmp_path / ".lock").read_text() == f"{os.getpid()}\n"
    with pytest.raises(RunFolderBusy, match=f"process id {os.getpid()}, this process"):
        RunLock.acquire(tmp_path)  # flock belongs to the open file: a second Run here is refused too
    (tmp_path.parent / f"{tmp_path.name}-link").symlink_to(tmp_path)  # the same folder by another name
    with pytest.raises(RunFolderBusy):
        RunLock.acquire(tmp_path.parent / f"{tmp_path.name}-link")
    lock.release()
    lock.release()
    with RunLock.acquire(tmp_path):
        pass
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / ".lock").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(UsageError, match="is a symbolic link"):
        RunLock.acquire(tmp_path / "other")
    assert not (tmp_path / "elsewhere").exists()


def test_a_lock_holder_killed_with_sigkill_frees_the_folder(tmp_path):
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time; from sim2real.run_lock import RunLock; "
                               f"lock = RunLock.acquire({str(tmp_path)!r}); print('held', flush=True); time.sleep(60)"],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(RunFolderBusy, match=f"process id {holder.pid}"):
            RunLock.acquire(tmp_path)
    finally:
        holder.kill()
        holder.wait()
    RunLock.acquire(tmp_path).release()


# -- controller values against the robot -----------------------------------------------------------
@pytest.fixture
def valid(controller) -> dict:
    return json.loads(controller.read_text())


def _save(tmp_path: Path, data: dict) -> Path:
    path = tmp_path / "c.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize("joint, value", [("right_ankle_pitch", math.radians(85)), ("left_ankle_roll", -0.5),
                                          ("right_ankle_roll", 3.0)])
def test_a_hold_angle_outside_its_joints_range_is_refused_naming_the_range(joint, value, valid, tmp_path, capsys):
    valid["joints"]["hold_rad"][joint] = value
    path = _save(tmp_path, valid)
    Controller.load(path)  # the format alone cannot tell: any angle within +-2 pi
    low, high = (math.degrees(a) for a in ROBOT.joint(joint).range_rad)
    with pytest.raises(ConfigError, match=rf"joints.hold_rad.{joint}: .* outside the joint's range .*"
                                          rf"\[{low:.1f}, {high:.1f}\] deg"):
        Controller.load(path, ROBOT)
    assert_usage_error(biped(["run", path, "--bus", "mock"], capsys), "hold_rad", joint)


@pytest.mark.parametrize("tick_s, why", [(0.002, "bus cycle"), (0.0029, "bus cycle"), (0.06, "Bus Watchdog"),
                                         (1.0, "Bus Watchdog")])
def test_a_tick_the_robots_bus_cannot_keep_is_refused_saying_what_was_checked(tick_s, why, valid, tmp_path, capsys):
    valid["tick_s"] = tick_s
    path = _save(tmp_path, valid)
    Controller.load(path)  # within the format's [0.001, 1] s
    with pytest.raises(ConfigError, match=rf"tick_s: {tick_s} s is outside the ticks robot xl430_biped can run at, "
                                          rf"\[5, 50\] ms: .*{why}.*its own tick is 34 ms"):
        Controller.load(path, ROBOT)
    for argv in (["run", path, "--bus", "mock"], ["dry-run", path], ["eval", path]):
        assert_usage_error(biped(argv, capsys), "tick_s", "bus cycle")


@pytest.mark.parametrize("tick_s", [0.005, 0.02, 0.034, 0.05])
def test_a_tick_other_than_the_robots_within_its_bounds_is_accepted(tick_s, valid, tmp_path):
    valid["tick_s"] = tick_s
    assert Controller.load(_save(tmp_path, valid), ROBOT).tick_s == tick_s


def test_tick_bounds_of_each_robot():
    # 300 bytes at 1 Mbps, and 1 ms of the host's turnaround for each of the two reads
    assert tick_bounds(ROBOT)[:2] == pytest.approx((0.005, 0.05))
    assert tick_bounds(load_robot("op3_legs"))[:2] == pytest.approx((321e-5 / 2 + 0.002, 0.05))  # 321 bytes at 2 Mbps
    low, high, why = tick_bounds(load_robot("human"))  # no bus: simulation only
    assert (low, high) == (0.002, 1.0) and "physics step" in why


def test_the_shipped_controllers_pass_the_robot_checks():
    from sim2real.robot.paths import data_root

    for path in sorted((data_root() / "configs" / "controllers").glob("*.json")):
        Controller.load_for_robot(path)


# -- traces that pass the format but mean nothing -----------------------------------------------------
def _spoil(path: Path, column: str, values: dict[int, str]) -> Path:
    """Set ``column`` in the given data rows (0 = the first) of a trace to ``values``."""
    lines = path.read_text().splitlines()
    j = lines[0].split(",").index(column)
    for k, text in values.items():
        cells = lines[k + 1].split(",")
        cells[j] = text
        lines[k + 1] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("value, names", [
    ("1e300", ["row 3", "right_knee_present_rad", "full turn"]),
    ("-7.0", ["row 3", "right_knee_present_rad", "full turn"]),
    ("57.3", ["row 3", "right_knee_present_rad", "degrees?"]),
    ("2.2", ["row 3", "right_knee_present_rad", "126.1 deg", "[0.0, 100.0] deg", "range_deg"]),
    ("-0.3", ["row 3", "right_knee_present_rad", "outside the joint's range"]),
])
def test_compare_refuses_an_angle_no_joint_takes(value, names, tmp_path, capsys):
    path = _spoil(write_trace(tmp_path / "t.csv"), "right_knee_present_rad", {1: value})
    assert_usage_error(biped(["compare", path], capsys), "t.csv", *names)


def test_an_angle_a_little_past_the_range_is_a_reading_not_an_error(tmp_path, capsys):
    """Encoders overshoot a stop by a degree or two, and calibration is not exact."""
    path = _spoil(write_trace(tmp_path / "t.csv"), "right_knee_present_rad", {1: f"{math.radians(-5):.6f}"})
    assert biped(["compare", path, "--json"], capsys).code == 0


def test_a_goal_outside_the_range_is_refused_too(tmp_path, capsys):
    path = _spoil(write_trace(tmp_path / "t.csv"), "waist_yaw_goal_rad", {0: "1.2"})
    assert_usage_error(biped(["compare", path], capsys), "row 2", "waist_yaw_goal_rad", "[-45.0, 45.0] deg")


@pytest.mark.parametrize("times, names", [
    (["-5", "-4.966", "0.068", "0.102", "0.136", "0.170"], ["row 2", "time_s -5", "negative"]),
    (["1.7e9", "1.7e9", "1.7e9", "1.7e9", "1.7e9", "1.7e9"], ["row 2", "more than a week"]),
    (["0", "0.034", "0.034", "0.102", "0.136", "0.170"], ["row 4", "does not increase"]),
])
def test_compare_refuses_times_no_loop_writes(times, names, tmp_path, capsys):
    path = _spoil(write_trace(tmp_path / "t.csv"), "time_s", dict(enumerate(times)))
    assert_usage_error(biped(["compare", path], capsys), "t.csv", *names)


def test_a_gap_in_time_is_said_plainly_and_counted(tmp_path, capsys):
    """The issue's trace without its negative start: a 5 s gap.  The loop writes no row for a
    tick whose reads failed and holds the goals, so a gap is replayable - and news."""
    path = _spoil(write_trace(tmp_path / "t.csv"), "time_s", {3: "5.102", 4: "5.136", 5: "5.170"})
    result = biped(["compare", path, "--json"], capsys)
    assert result.code == 0, result.err
    notes = json.loads(result.out)["notes"]
    assert len(notes) == 1 and "1 gap(s) of more than 3 ticks" in notes[0] and "the longest 5.034 s" in notes[0]
    assert "row 4" in notes[0] and "note:" in result.err
    short = _spoil(write_trace(tmp_path / "u.csv"), "time_s", {3: "0.170", 4: "0.204", 5: "0.238"})  # 2 ticks missed
    assert json.loads(biped(["compare", short, "--json"], capsys).out)["notes"] == []


def test_times_in_milliseconds_are_noted_as_gaps_of_the_sidecars_tick(tmp_path, capsys):
    path = _spoil(write_trace(tmp_path / "t.csv"), "time_s", {k: str(34 * k) for k in range(6)})
    result = biped(["compare", path, "--json"], capsys)
    assert "5 gap(s)" in json.loads(result.out)["notes"][0]


def test_plot_gait_of_a_trace_refuses_an_angle_past_a_full_turn(tmp_path, capsys):
    path = _spoil(write_trace(tmp_path / "t.csv"), "left_knee_present_rad", {0: "1e300"})
    assert_usage_error(biped(["plot", "gait", "--trace", path, "-o", tmp_path / "g.png"], capsys),
                       "t.csv", "row 2", "full turn")
    assert not (tmp_path / "g.png").exists()


# -- sysid: only what it can fit ------------------------------------------------------------------------
def _walk(path: Path, metadata: dict) -> Path:
    """A trace of 3 s with moving goals, as `biped run` writes it (no excitation program)."""
    home = np.array([j.home_rad for j in ROBOT.joints])
    writer = TraceWriter(path, ROBOT.joint_names, metadata)
    for k in range(90):
        goal = home + 0.2 * math.sin(k / 5)
        writer.write(k * 0.034, k, goal, goal, [1, 0], [0.0, 0.0, 1.0], 1e-4, 1e-3, False)
    writer.close()
    return path


def test_sysid_refuses_a_walk_from_biped_run(tmp_path, capsys):
    pytest.importorskip("scipy")
    path = _walk(tmp_path / "walk.csv", {"robot": ROBOT.name, "tick_s": 0.034, "controller_hash": "0" * 16})
    result = biped(["sysid", path, "-o", tmp_path / "fit.yaml"], capsys)
    assert_usage_error(result, "walk.csv", "excitation.pose", "not a `biped excite` trace", "biped compare")
    assert not (tmp_path / "fit.yaml").exists()


@pytest.mark.parametrize("segments", ["all", [{"group": "knee", "kind": "chirp", "start": 5}],
                                      [{"group": "knee", "kind": "chirp", "start": 9, "end": 3}]])
def test_sysid_refuses_excitation_segments_it_cannot_cut(segments, tmp_path, capsys):
    pytest.importorskip("scipy")
    meta = {"robot": ROBOT.name, "tick_s": 0.034, "excitation": {"pose": "suspended", "segments": segments}}
    path = _walk(tmp_path / "e.csv", meta)
    assert_usage_error(biped(["sysid", path], capsys), "e.json", "excitation.segments")
