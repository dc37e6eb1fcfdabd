"""Hostile model files (issue 47, item 2): what an MJCF or URDF can name or hold that would hang,
crash or fool the tool, refused before MuJoCo opens anything, with the element named.

* files the model names (include, mesh, texture, skin, height field, URDF mesh) that are a
  named pipe (MuJoCo blocked on it for ever), a device, a directory, a symlink loop, too large,
  outside the model's folders, or missing with a near match (``.STL`` for ``.stl``);
* includes in a cycle or too deep; XML nested 100,000 deep (MJCF: MuJoCo's parser; URDF: a
  RecursionError); DTDs (entity expansion);
* models that expand to too much: a huge ``<composite>``, nested ``<replicate>``, a
  10,000-joint chain, 10,000 geoms;
* NaN or infinity in a joint origin, axis, limit, body position or keyframe, MJCF and URDF;
  a joint axis of length 0;
* MuJoCo's own refusal (a bad texture, a bad skin) passed on, not called an inertia problem.

Whatever could block (a FIFO) or crash (deep nesting) runs the real CLI in a subprocess with a
timeout, so that a regression fails the test instead of hanging the suite; the rest runs in
process under an alarm.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from hang_guard import fails_after
from robots.urdf_humanoid import write_humanoid, write_prism_stl

from evolve.cli import main
from sim2real.errors import ConfigError
from sim2real.simulation.model import guard as model_guard
from sim2real.simulation.model.files import add_free_joint, load_model_spec

ROOT = Path(__file__).resolve().parent.parent
TIMEOUT_S = 90  # a refusal takes a few seconds (most of it importing MuJoCo); a hang never ends
MJCF = """<mujoco model="m">
  <compiler angle="radian"/>
  {head}
  <worldbody>
    <body name="trunk" pos="0 0 0.5">
      <freejoint/>
      <geom name="torso" type="box" size="0.05 0.1 0.1"/>
      <body name="r_thigh" pos="0 -0.05 -0.1">
        <joint name="r_hip_pitch" axis="0 1 0" pos="0 0 0" range="-1 1"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02"/>
      </body>
      <body name="l_thigh" pos="0 0.05 -0.1">
        <joint name="l_hip_pitch" axis="0 1 0" range="-1 1"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02"/>
      </body>
      {body}
    </body>
  </worldbody>
  {tail}
</mujoco>
"""
URDF = """<robot name="r">
  <link name="base">
    <inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><geometry><box size="0.1 0.2 0.2"/></geometry></collision>
  </link>
  <link name="r_thigh">
    <inertial><origin xyz="0 0 -0.1" rpy="0 0 0"/><mass value="0.2"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.0001"/></inertial>
    <collision><geometry>{geometry}</geometry></collision>
  </link>
  <joint name="r_hip_pitch" type="revolute">
    <parent link="base"/><child link="r_thigh"/>
    <origin xyz="0 -0.05 -0.1" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="4" velocity="5"/>
  </joint>
</robot>
"""
BOX = '<box size="0.04 0.04 0.2"/>'


@pytest.fixture(autouse=True)
def no_hang():
    """An in-process load that blocks fails after 30 s instead of hanging the suite."""
    with fails_after(30):
        yield


def mjcf(folder: Path, head: str = "", body: str = "", tail: str = "", name: str = "robot.xml") -> Path:
    path = folder / name
    path.write_text(MJCF.format(head=head, body=body, tail=tail))
    return path


def urdf(folder: Path, geometry: str = BOX, text: str | None = None) -> Path:
    path = folder / "robot.urdf"
    path.write_text(text if text is not None else URDF.format(geometry=geometry))
    return path


def refusal(path: Path, package_dirs=()) -> str:
    """The one-line refusal of loading ``path``, which names it."""
    with pytest.raises(ConfigError) as err:
        load_model_spec(path, package_dirs)
    message = str(err.value)
    assert message.startswith(f"{path}: ") and "\n" not in message, message
    return message


def cli(tmp_path: Path, *argv: str) -> subprocess.CompletedProcess:
    """``biped argv`` in a subprocess that a hang cannot outlive (then the test fails)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    try:
        return subprocess.run([sys.executable, "-m", "evolve.cli", *argv], capture_output=True, text=True,
                              timeout=TIMEOUT_S, cwd=tmp_path, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail(f"biped {' '.join(argv)} still ran after {TIMEOUT_S} s")


def cli_refusal(tmp_path: Path, path: Path, *more: str) -> str:
    """``biped robot import PATH`` refused: exit 2, one line naming the file, nothing written."""
    out = tmp_path / "robot.yaml"
    done = cli(tmp_path, "robot", "import", str(path), "-o", str(out), *more)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"biped: error: {path}: "), done.stderr
    assert not out.exists()
    return lines[0]


# -- files a model names that are no regular files ---------------------------------------------
ROLES = {  # role -> (MJCF head, MJCF body) naming the file "part"
    "include": ('<include file="part"/>', ""),
    "mesh": ('<asset><mesh name="m" file="part"/></asset>', '<geom type="mesh" mesh="m"/>'),
    "texture": ('<asset><texture name="t" type="2d" file="part"/><material name="mat" texture="t"/></asset>',
                '<geom type="sphere" size="0.01" material="mat"/>'),
    "skin": ('<asset><skin name="s" file="part"/></asset>', ""),
    "hfield": ('<asset><hfield name="h" file="part" size="1 1 0.1 0.1"/></asset>', ""),
    "model": ('<asset><model name="arm" file="part"/></asset>', ""),  # an MJCF to attach
}


@pytest.mark.parametrize("role", [*ROLES, "urdf mesh"])
def test_a_fifo_named_by_a_model_is_refused_unopened_by_robot_import(tmp_path, role):
    os.mkfifo(tmp_path / "part")  # MuJoCo would open it for reading and wait for a writer, for ever
    if role == "urdf mesh":
        path = urdf(tmp_path, geometry='<mesh filename="part"/>')
    else:
        path = mjcf(tmp_path, *ROLES[role])
    line = cli_refusal(tmp_path, path)
    assert "part" in line and "is a named pipe (FIFO)" in line
    assert ("<mesh>" if role == "urdf mesh" else f"<{role}") in line


@pytest.mark.parametrize("kind", ["device", "directory", "symlink loop", "symlink to a fifo"])
@pytest.mark.parametrize("role", list(ROLES))
def test_a_device_directory_or_bad_symlink_named_by_a_model_is_refused(tmp_path, role, kind):
    part = tmp_path / "part"
    if kind == "device":
        part.symlink_to("/dev/zero")  # never ends
    elif kind == "directory":
        part.mkdir()
    elif kind == "symlink loop":
        part.symlink_to(tmp_path / "loop")
        (tmp_path / "loop").symlink_to(part)
    else:
        os.mkfifo(tmp_path / "pipe")
        part.symlink_to(tmp_path / "pipe")
    message = refusal(mjcf(tmp_path, *ROLES[role]))
    assert f"<{role}" in message and 'file="part"' in message and "line " in message
    assert {"device": "is a character device", "directory": "is a directory", "symlink loop":
            "Too many levels of symbolic links", "symlink to a fifo": "named pipe"}[kind] in message


def test_an_oversized_mesh_or_include_is_refused_unread(tmp_path):
    mesh = tmp_path / "huge.stl"
    with open(mesh, "wb") as f:
        f.truncate(model_guard.MAX_ASSET_BYTES + 1)  # sparse: no disk used
    message = refusal(mjcf(tmp_path, '<asset><mesh name="m" file="huge.stl"/></asset>', '<geom type="mesh" mesh="m"/>'))
    assert f"huge.stl has {model_guard.MAX_ASSET_BYTES + 1} bytes, more than the 64 MB" in message
    part = tmp_path / "part.xml"
    with open(part, "wb") as f:
        f.truncate(model_guard.MAX_MODEL_BYTES + 1)
    message = refusal(mjcf(tmp_path, '<include file="part.xml"/>'))
    assert "<include>" in message and "more than the 16 MB" in message


def test_a_file_outside_the_models_folders_is_refused_unless_its_folder_is_given(tmp_path):
    model_dir, elsewhere = tmp_path / "a" / "robot", tmp_path / "b"
    model_dir.mkdir(parents=True), elsewhere.mkdir()
    write_prism_stl(elsewhere / "thigh.stl", 0.02, 0.2)
    path = mjcf(model_dir, f'<asset><mesh name="m" file="{elsewhere / "thigh.stl"}"/></asset>',
                '<geom type="mesh" mesh="m"/>')
    assert "outside the folders a model's files may come from" in refusal(path)
    load_model_spec(path, [elsewhere])  # the user named its folder
    # the kernel's files are no model's, wherever the model is
    proc = mjcf(model_dir, '<asset><texture name="t" type="2d" file="/proc/self/status"/></asset>')
    assert "/proc/self/status is outside the folders" in refusal(proc)


# -- includes ---------------------------------------------------------------------------------
def test_an_include_cycle_is_refused_naming_the_files(tmp_path):
    (tmp_path / "a.xml").write_text('<mujoco><include file="b.xml"/></mujoco>')
    (tmp_path / "b.xml").write_text('<mujoco><include file="a.xml"/></mujoco>')
    message = refusal(mjcf(tmp_path, '<include file="a.xml"/>'))
    assert "b.xml line 1: <include>: a cycle of includes: a.xml -> b.xml -> a.xml" in message
    itself = mjcf(tmp_path, '<include file="self.xml"/>', name="self.xml")
    assert "a cycle of includes: self.xml -> self.xml" in refusal(itself)


def test_includes_nested_too_deep_are_refused(tmp_path):
    depth = model_guard.MAX_INCLUDE_DEPTH + 2
    for i in range(depth):
        (tmp_path / f"i{i}.xml").write_text(f'<mujoco><include file="i{i + 1}.xml"/></mujoco>')
    (tmp_path / f"i{depth}.xml").write_text("<mujoco/>")
    assert f"includes nested more than {model_guard.MAX_INCLUDE_DEPTH} deep" in refusal(
        mjcf(tmp_path, '<include file="i0.xml"/>'))
    # as deep as allowed loads
    (tmp_path / f"i{model_guard.MAX_INCLUDE_DEPTH - 1}.xml").write_text("<mujoco><asset/></mujoco>")
    load_model_spec(mjcf(tmp_path, '<include file="i0.xml"/>'))


def test_a_missing_include_names_a_file_differing_only_in_case(tmp_path):
    (tmp_path / "Parts.XML").write_text("<mujoco/>")
    message = refusal(mjcf(tmp_path, '<include file="parts.xml"/>'))
    assert 'file="parts.xml": not found' in message and "there is Parts.XML (names differ in case" in message


# -- nesting, DTDs, sizes -----------------------------------------------------------------------
def test_mjcf_nested_100000_deep_is_refused_by_robot_import(tmp_path):
    path = tmp_path / "deep.xml"
    n = 100_000
    path.write_text('<mujoco><worldbody>' + '<body><geom size=".1"/>' * n + "</body>" * n + "</worldbody></mujoco>")
    line = cli_refusal(tmp_path, path)
    assert f"XML nested more than {model_guard.MAX_XML_DEPTH} elements deep" in line


def test_urdf_nested_100000_deep_is_refused_without_recursion(tmp_path):
    n = 100_000
    path = urdf(tmp_path, text='<robot name="r">' + "<link>" * n + "</link>" * n + "</robot>")
    message = refusal(path)
    assert f"line 1: XML nested more than {model_guard.MAX_XML_DEPTH} elements deep" in message


def test_deep_nesting_through_includes_is_refused(tmp_path):
    half = model_guard.MAX_XML_DEPTH // 2 + 5
    (tmp_path / "deep.xml").write_text("<mujoco><worldbody>" + "<body>" * half + '<include file="deeper.xml"/>'
                                       + "</body>" * half + "</worldbody></mujoco>")
    (tmp_path / "deeper.xml").write_text("<mujoco>" + "<body>" * half + "</body>" * half + "</mujoco>")
    message = refusal(mjcf(tmp_path, '<include file="deep.xml"/>'))
    assert "deeper.xml line 1: <body>" in message and "elements deep, counting includes" in message


def test_more_elements_than_any_robot_has_are_refused_while_parsing(tmp_path):
    path = mjcf(tmp_path, body='<site size=".01"/>' * (model_guard.MAX_ELEMENTS + 1))
    assert f"more than {model_guard.MAX_ELEMENTS} XML elements" in refusal(path)


BOMB = ('<?xml version="1.0"?><!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;">'
        '<!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;">]><mujoco model="&lol3;"/>')


def test_a_dtd_is_refused_in_an_include_and_at_the_top(tmp_path):
    (tmp_path / "bomb.xml").write_text(BOMB)
    message = refusal(mjcf(tmp_path, '<include file="bomb.xml"/>'))
    assert "bomb.xml: line 1: a DTD (<!DOCTYPE>) is not accepted" in message
    # an external DTD declares no entity in the file, and is refused all the same
    external = tmp_path / "external.xml"
    external.write_text('<?xml version="1.0"?><!DOCTYPE mujoco SYSTEM "file:///dev/zero">'
                        + MJCF.format(head="", body="", tail=""))
    assert "a DTD (<!DOCTYPE>) is not accepted" in refusal(external)


# -- models that expand to too much: each would hang the import --------------------------------
EXPANDING = {
    "huge composite": ('<body name="rope" pos="0 0 1"><composite type="cable" count="200000 1 1" size="1">'
                       '<geom type="capsule" size=".001"/></composite></body>', "bodies"),
    "nested replicate": ('<replicate count="100"><replicate count="100"><replicate count="100">'
                         '<body><joint/><geom size=".01"/></body></replicate></replicate></replicate>', "joints"),
    "10,000 geoms": ('<body name="b">' + '<geom size=".01"/>' * 10_000 + "</body>", "geoms"),
}


@pytest.mark.parametrize("case", list(EXPANDING))
def test_an_mjcf_that_expands_to_too_much_is_refused_by_robot_import(tmp_path, case):
    body, what = EXPANDING[case]
    line = cli_refusal(tmp_path, mjcf(tmp_path, body=body))
    assert f"{what} (counting what <replicate>, <composite> and <flexcomp> make), more than the" in line


def test_a_10000_joint_urdf_chain_is_refused_by_robot_import(tmp_path):
    n = 10_000
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))  # few elements: the joints are counted
    joints = "".join(f'<joint name="j{i}" type="continuous"><parent link="l{i}"/><child link="l{i + 1}"/>'
                     f'<axis xyz="0 1 0"/></joint>' for i in range(n))
    path = urdf(tmp_path, text=f'<robot name="chain">{links}{joints}</robot>')
    line = cli_refusal(tmp_path, path)
    assert f"{n} joints (counting" in line and f"more than the {model_guard.MAX_JOINTS}" in line


# -- numbers --------------------------------------------------------------------------------------
MJCF_NUMBERS = {  # what -> (old text, new text, the element and attribute named)
    "joint origin": ('<joint name="r_hip_pitch" axis="0 1 0" pos="0 0 0"', '<joint name="r_hip_pitch" axis="0 1 0" '
                     'pos="nan 0 0"', "<joint name='r_hip_pitch'>: pos holds 'nan': NaN"),
    "joint axis": ('name="l_hip_pitch" axis="0 1 0"', 'name="l_hip_pitch" axis="0 inf 0"',
                   "<joint name='l_hip_pitch'>: axis holds 'inf': infinite"),
    "joint limit": ('name="l_hip_pitch" axis="0 1 0" range="-1 1"', 'name="l_hip_pitch" axis="0 1 0" range="-1e999 1"',
                    "<joint name='l_hip_pitch'>: range holds '-1e999': infinite"),
    "body position": ('<body name="r_thigh" pos="0 -0.05 -0.1">', '<body name="r_thigh" pos="0 -0.05 NaN">',
                      "<body name='r_thigh'>: pos holds 'NaN': NaN"),
    "keyframe": ("{tail}", '<keyframe><key name="home" qpos="0 0 0.5 1 0 0 0 nan 0"/></keyframe>',
                 "<key name='home'>: qpos holds 'nan': NaN"),
    "hex float": ('<geom name="torso" type="box"', '<geom name="torso" mass="0x1p9999" type="box"',
                  "<geom name='torso'>: mass holds '0x1p9999': infinite"),
}


@pytest.mark.parametrize("what", list(MJCF_NUMBERS))
def test_nan_or_inf_in_an_mjcf_is_refused_naming_the_element(tmp_path, what):
    old, new, named = MJCF_NUMBERS[what]
    text = MJCF.replace(old, new)
    assert text != MJCF
    path = tmp_path / "robot.xml"
    path.write_text(text.format(head="", body="", tail=""))
    message = refusal(path)
    assert named in message and "line " in message


URDF_NUMBERS = {
    "joint origin": ('<origin xyz="0 -0.05 -0.1"', '<origin xyz="0 -0.05 nan"', "<origin> in <joint name='r_hip_pitch'>"),
    "joint axis": ('<axis xyz="0 1 0"/>', '<axis xyz="0 inf 0"/>', "<axis> in <joint name='r_hip_pitch'>"),
    "joint limit": ('lower="-1"', 'lower="-inf"', "<limit> in <joint name='r_hip_pitch'>"),
    "body position": ('<origin xyz="0 0 -0.1" rpy="0 0 0"/>', '<origin xyz="0 0 -0.1" rpy="0 NaN 0"/>',
                      "<origin> in <link name='r_thigh'>"),
    "body mass": ('<mass value="0.2"/>', '<mass value="nan"/>', "<mass> in <link name='r_thigh'>"),
}


@pytest.mark.parametrize("what", list(URDF_NUMBERS))
def test_nan_or_inf_in_a_urdf_is_refused_naming_the_element(tmp_path, what):
    old, new, named = URDF_NUMBERS[what]
    text = URDF.format(geometry=BOX)
    assert old in text
    message = refusal(urdf(tmp_path, text=text.replace(old, new, 1)))
    assert named in message and "line " in message and ("NaN" in message or "infinite" in message)


def test_a_nan_keyframe_is_refused_by_robot_import_in_words(tmp_path):
    path = mjcf(tmp_path, tail='<keyframe><key name="home" qpos="0 0 0.5 1 0 0 0 nan 0"/></keyframe>')
    line = cli_refusal(tmp_path, path)
    assert "<key name='home'>: qpos holds 'nan': NaN" in line and "convert" not in line


def test_names_that_read_as_numbers_are_no_numbers(tmp_path):
    text = MJCF.format(head="", body="", tail="").replace('name="r_thigh"', 'name="inf"').replace(
        'name="torso"', 'name="nan"')
    path = tmp_path / "robot.xml"
    path.write_text(text)
    assert load_model_spec(path).body("inf") is not None


@pytest.mark.parametrize("where", ["mjcf joint", "mjcf default", "urdf"])
def test_a_zero_joint_axis_is_refused_as_such(tmp_path, where):
    if where == "urdf":
        path = urdf(tmp_path, text=URDF.format(geometry=BOX).replace('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>'))
        named = "<axis> in <joint name='r_hip_pitch'>"
    elif where == "mjcf joint":
        path = tmp_path / "robot.xml"
        path.write_text(MJCF.format(head="", body="", tail="").replace('name="l_hip_pitch" axis="0 1 0"',
                                                                       'name="l_hip_pitch" axis="0 0 0"'))
        named = "<joint name='l_hip_pitch'>"
    else:
        path = mjcf(tmp_path, head='<default><joint axis="0 0 0"/></default>')
        named = "<joint>"
    message = refusal(path)
    assert f'{named}: ' in message and '="0 0 0": a joint axis of length 0 has no direction' in message


# -- MuJoCo's own words -------------------------------------------------------------------------
@pytest.mark.parametrize("asset, words", [
    ('<texture name="t" type="2d" file="bad.png"/><material name="mat" texture="t"/>',
     "error decoding PNG file"),
    ('<skin name="s" file="bad.skn"/>', "missing header in SKN file"),
])
def test_a_bad_texture_or_skin_is_reported_in_mujocos_words(tmp_path, capsys, asset, words):
    (tmp_path / "bad.png").write_text("not a png")
    (tmp_path / "bad.skn").write_bytes(b"\x01\x00\x00\x00" * 3)
    path = mjcf(tmp_path, f"<asset>{asset}</asset>")
    assert main(["robot", "import", str(path), "-o", str(tmp_path / "robot.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"biped: error: {path}: MuJoCo cannot compile the model: ") and words in err
    assert "Element name" in err and "inertias" not in err


# -- near matches and the robots that must still load --------------------------------------------
def test_a_missing_mesh_names_the_file_differing_in_case_or_extension(tmp_path):
    files = write_humanoid(tmp_path)
    (tmp_path / "meshes" / "thigh.stl").rename(tmp_path / "meshes" / "thigh.STL")
    (tmp_path / "meshes" / "head.stl").rename(tmp_path / "meshes" / "head.obj")
    message = str(pytest.raises(ConfigError, load_model_spec, files.urdf).value)
    assert f"there is {tmp_path / 'meshes' / 'thigh.STL'} (names differ in case or extension)" in message
    assert f"there is {tmp_path / 'meshes' / 'head.obj'}" in message


def test_robot_show_of_a_robot_whose_model_names_a_fifo_is_refused(tmp_path):
    files = write_humanoid(tmp_path)
    spec = load_model_spec(files.urdf)
    add_free_joint(spec)
    model = tmp_path / "humanoid.xml"
    model.write_text(spec.to_xml())
    out = tmp_path / "humanoid.yaml"
    assert main(["robot", "import", str(model), "--servo", "XM430-W350", "-o", str(out)]) == 0
    # the model, once imported, gains a texture; the texture is a FIFO
    model.write_text(spec.to_xml().replace(
        "<worldbody>", '<asset><texture name="skin" type="2d" file="skin.png"/></asset><worldbody>', 1))
    os.mkfifo(tmp_path / "skin.png")
    done = cli(tmp_path, "robot", "show", str(out))
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.strip().startswith(f"biped: error: {model}: ")
    assert "<texture name='skin'>" in done.stderr and "named pipe" in done.stderr
