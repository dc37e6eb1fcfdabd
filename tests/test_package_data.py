"""What `pip install .` (not editable) installs: the code, and every data file the code reads at
run time, where ``sim2real.robot.paths.data_root`` finds it; never the benchmark records.

An installed copy reads ``configs/`` and ``firmware_profiles/`` from ``<prefix>/share/biped``
(``data_root``), which ``[tool.setuptools.data-files]`` fills.  A robot YAML names its model
file relative to itself (``model.file: op3/op3.xml``), so a file under a sub-folder of
``configs/robots/`` must land in the same sub-folder there, or the robot loads in a clone and not
in an installed copy.  The wheel itself is not built here (that needs the network for its build
requirements); the settings that decide its content are read instead.
"""

from __future__ import annotations

import fnmatch
import tomllib
from pathlib import Path, PurePosixPath

from tests.test_links import FILES

ROOT = Path(__file__).resolve().parent.parent
SETUPTOOLS = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
DATA_ROOT = PurePosixPath("share/biped")  # sim2real/robot/paths.py: sys.prefix / "share" / "biped"


def globbed(path: str, pattern: str) -> bool:
    """Whether setuptools' glob ``pattern`` names ``path`` (a ``*`` stays within one folder)."""
    parts, wanted = path.split("/"), pattern.split("/")
    return len(parts) == len(wanted) and all(map(fnmatch.fnmatchcase, parts, wanted))


def unshipped(files: list[str], data_files: dict[str, list[str]]) -> list[str]:
    """The files no data-files entry installs under DATA_ROOT at their own relative path (an
    entry puts every file it names straight into its target folder)."""
    return [f for f in files
            if not any(PurePosixPath(target) == DATA_ROOT / PurePosixPath(f).parent
                       and any(globbed(f, pattern) for pattern in patterns)
                       for target, patterns in data_files.items())]


def test_every_runtime_data_file_is_installed_where_the_code_looks():
    runtime = sorted(f for f in FILES if f.startswith(("configs/", "firmware_profiles/")))
    assert "configs/robots/op3/op3.xml" in runtime and "firmware_profiles/xl430_w250_t.yaml" in runtime
    missing = unshipped(runtime, SETUPTOOLS["data-files"])
    assert not missing, "not installed by [tool.setuptools.data-files] at share/biped/<its folder>: " + ", ".join(missing)


def test_no_record_or_benchmark_is_packaged():
    assert SETUPTOOLS["packages"]["find"]["include"] == ["evolve*", "sim2real*"]  # not benchmarks, not tests
    shipped = [p for patterns in SETUPTOOLS["data-files"].values() for p in patterns]
    shipped += [p for patterns in SETUPTOOLS.get("package-data", {}).values() for p in patterns]
    assert not [p for p in shipped if p.startswith(("benchmarks", "tests"))], shipped
    assert not (ROOT / "MANIFEST.in").exists()  # would add files to the source distribution


def test_the_check_sees_a_file_left_out():
    """A model file beside a robot YAML is not installed by the robots' own `*.yaml` glob, nor by
    a glob sending it to the wrong folder; a glob does not reach into sub-folders."""
    files = ["configs/robots/op3.yaml", "configs/robots/op3/op3.xml"]
    assert unshipped(files, {"share/biped/configs/robots": ["configs/robots/*.yaml"]}) == ["configs/robots/op3/op3.xml"]
    assert unshipped(files, {"share/biped/configs/robots": ["configs/robots/*.yaml", "configs/robots/op3/*"]}) == [
        "configs/robots/op3/op3.xml"]
    assert unshipped(files, {"share/biped/configs/robots": ["configs/robots/*"]}) == ["configs/robots/op3/op3.xml"]
    assert unshipped(files, {"share/biped/configs/robots": ["configs/robots/*.yaml"],
                             "share/biped/configs/robots/op3": ["configs/*"]}) == ["configs/robots/op3/op3.xml"]
    assert unshipped(files, {"share/biped/configs/robots": ["configs/robots/*.yaml"],
                             "share/biped/configs/robots/op3": ["configs/robots/op3/*"]}) == []
