"""Reading robot configs (``configs/robots/*.yaml``) into a :class:`~sim2real.robot.spec.RobotSpec`:
every key checked, with the file, the key and the problem in each error.  Physical quantities
must lie in the plausible ranges of :mod:`sim2real.robot.spec` (each box side, foot dimension
and hip spacing 0.002-1.5 m, each segment 0.005-200 kg, joint angles within a turn either way,
PD gains and torque caps, the control tick 1 ms-1 s); a human character's body scaled from its
anthropometry is held to the same ranges.  At most 64 joints, names at most 64 characters.
A PD robot's body is the box tree scaled from anthropometry or a model file (``model:``); a
torque cap per kg multiplies the anthropometry's mass, or the model's once it is measured.

    robot = load_robot("xl430_biped")          # or a path, or "human:female_50"
"""

from __future__ import annotations

import math
from pathlib import Path

from sim2real.errors import ConfigError
from sim2real.robot import anthropometry
from sim2real.robot.anatomy import DEFAULT_FORWARD, FORWARDS
from sim2real.robot.paths import robots_dir
from sim2real.robot.profiles import DeviceProfile, load_profile
from sim2real.robot.bus_plan import baud_problem
from sim2real.robot.spec import (
    AXES,
    CENTER_LOCATIONS,
    CONTROL_TICK_S,
    DEFAULT_CONTACT_SHARE,
    DEFAULT_ROBOT,
    JOINT_ANGLE_DEG,
    LOCATIONS,
    MAX_TORQUE_NM,
    MAX_TORQUE_NM_PER_KG,
    NO_LOAD_SPEED_FROUDE,
    PD_KD,
    PD_KP,
    PHYSICS_DT_S,
    SEGMENT_MASS_KG,
    SEGMENT_SIZE_M,
    SIDES,
    STIFFNESS_MGL,
    Body,
    Box,
    BusSettings,
    Foot,
    Joint,
    ModelFoot,
    ModelSource,
    PDGains,
    RobotSpec,
    SensorBoard,
    ServoMap,
)
from sim2real.robot.joint_map import box_location_problems, id_problems, joint_map_problems, raise_all
from sim2real.robot.validation import Node, load_yaml, show, show_name

SIZE = dict(lo=SEGMENT_SIZE_M[0], hi=SEGMENT_SIZE_M[1], unit="m",
            why=f"a plausible segment: {SEGMENT_SIZE_M[0]:g}-{SEGMENT_SIZE_M[1]:g} m")
MASS = dict(lo=SEGMENT_MASS_KG[0], hi=SEGMENT_MASS_KG[1], unit="kg",
            why=f"a plausible segment: {SEGMENT_MASS_KG[0]:g}-{SEGMENT_MASS_KG[1]:g} kg")
MAX_NAME = 64  # characters of a joint's or a control set's name
MAX_INDEX = 15  # joints of one role along one chain (a spine of five has index 0 and 1 per axis)
MAX_JOINTS = 64  # a biped's joints (the shipped robots have 11 and 15; a bus has IDs 0-252)
ANGLE = dict(lo=JOINT_ANGLE_DEG[0], hi=JOINT_ANGLE_DEG[1], unit="deg")

_ROBOT_KEYS = dict(
    required=("name", "description", "joints", "control_sets"),
    optional=(
        "body", "model", "actuation", "servo_model", "bus", "sensor_board", "pd_gains", "control_tick_s",
        "physics_dt_s", "anthropometry", "proportions", "shape",
    ),
)


def exists(path: Path) -> bool:
    """``path.exists()``, False for a name the system refuses (too long, a NUL byte) rather
    than an OSError: a name typed by hand or read from a file may be anything."""
    try:
        return path.exists()
    except (OSError, ValueError):
        return False


def resolve_robot_path(name_or_path: str | Path) -> tuple[Path, str | None]:
    """A robot name (``xl430_biped``, ``human:male_95``) or a path -> (file, preset).

    For a name or path given on the command line; a name read from a file goes through
    :func:`sim2real.robot.names.named_robot_path` instead, which never opens a path."""
    text = str(name_or_path)
    preset = None
    if ":" in text and not exists(Path(text)):
        text, preset = text.split(":", 1)
    if text in available_robots():  # the project's robot, even beside a file of that name in the cwd
        return robots_dir() / f"{text}.yaml", preset
    path = Path(text)
    if path.suffix in (".yaml", ".yml") or exists(path):
        if not exists(path):
            shown = str(path) if len(str(path)) <= 255 else show(str(path))  # a sane path whole
            raise FileNotFoundError(f"robot config {shown} does not exist")
        return path, preset
    candidate = robots_dir() / f"{text}.yaml"
    if not exists(candidate):
        known = ", ".join(available_robots())
        raise FileNotFoundError(f"unknown robot {show_name(text)} (known: {known}; or give a path)")
    return candidate, preset


def available_robots() -> list[str]:
    return sorted(p.stem for p in robots_dir().glob("*.yaml") if not p.stem.startswith("_"))


def load_robot(name_or_path: str | Path = DEFAULT_ROBOT) -> RobotSpec:
    """Read and validate a robot config; raises :class:`ConfigError` naming file and key."""
    path, preset = resolve_robot_path(name_or_path)
    return parse_robot(load_yaml(path), str(path), preset)


def parse_robot(doc: object, source: str, preset: str | None = None) -> RobotSpec:

    root = Node(doc, source).mapping(**_ROBOT_KEYS)
    actuation = root.get("actuation", "servo").string(("servo", "pd"))
    if actuation == "pd" and root.has("model"):  # a PD character drawn in its own model file
        _refuse_body_keys(root, preset)
        body, measures = None, {}
        pd = _read_pd(_pd_gains(root), None)  # a cap per kg waits for the model's measured mass
    elif actuation == "pd":
        body, measures = anthropometry.human_body(root, preset)
        _check_derived_body(root, body, str(measures["preset"]))
        pd = _read_pd(_pd_gains(root), float(measures["mass_kg"]))
    else:
        if preset is not None:
            raise root.error(f"robot has no presets, got {show(preset)}", key="name")
        for key in ("anthropometry", "proportions", "shape", "pd_gains"):
            if root.has(key):
                raise root.error("only allowed with actuation: pd", key=key)
        if root.has("body") == root.has("model"):
            raise root.error("give the robot's body (the box tree) or its model (an MJCF or URDF file), one of them",
                             key="model" if root.has("model") else "body")
        body, measures, pd = (_read_body(root["body"]) if root.has("body") else None), {}, None
    model = _read_model(root["model"], Path(source)) if root.has("model") else None

    default_model = root["servo_model"].string() if root.has("servo_model") else None
    problems: list[ConfigError] = []  # every joint's problems, listed together (one round of fixes)
    joints_list = []
    for node in root["joints"].list(1, MAX_JOINTS):
        try:
            joint = _read_joint(node, actuation == "servo", default_model, model is not None, problems)
        except ConfigError as exc:
            problems.append(exc)
            continue
        if joint is not None:
            joints_list.append(joint)
    joints = tuple(joints_list)
    problems += joint_map_problems(root, joints, complete=len(joints) == len(root["joints"].value))
    if model is None:
        problems += box_location_problems(root, joints)
    board = _read_sensor_board(root["sensor_board"]) if root.has("sensor_board") else None
    if actuation == "servo":
        for key in ("bus", "sensor_board"):
            if not root.has(key):
                problems.append(root.error(f"missing required key {key!r} for a servo robot", key=key))
        problems += id_problems(root, joints, board)
    raise_all(root.source, problems)
    bus = _read_bus(root["bus"]) if root.has("bus") else None
    if bus is not None:
        devices = {j.servo.id: j.servo.profile for j in joints if j.servo is not None}
        if board is not None:
            devices[board.id] = board.profile
        problem = baud_problem(devices, bus.baud)  # names the servos, by model and protocol
        if problem:
            raise root.error(problem, key="bus.baud")

    names = {j.name for j in joints}
    control_sets = {}
    for set_name, node in root["control_sets"].items():
        if len(set_name) > MAX_NAME or not set_name.isprintable():
            raise node.error(f"a control set's name is at most {MAX_NAME} printable characters")
        members = tuple(n.string() for n in node.list(1))
        for i, member in enumerate(members):
            if member not in names:
                raise node[i].error(f"unknown joint {show(member)}")
        control_sets[set_name] = members

    name = root["name"].string()
    return RobotSpec(
        name=f"{name}:{measures['preset']}" if measures else name,
        description=root["description"].string(),
        source=source,
        body=body,
        joints=joints,
        control_sets=control_sets,
        bus=bus,
        sensor_board=board,
        pd=pd,
        control_tick_s=root["control_tick_s"].number(*CONTROL_TICK_S, unit="s") if root.has("control_tick_s") else None,
        physics_dt_s=root["physics_dt_s"].number(*PHYSICS_DT_S, unit="s") if root.has("physics_dt_s") else None,
        anthropometry={k: v for k, v in measures.items() if k != "preset"},
        model=model,
    )


def _read_model(node: Node, config: Path) -> ModelSource:
    """The ``model:`` block: the file (relative to the robot config), where its parts are.
    That the names exist in the file is checked when the model is built (MuJoCo reads it)."""
    node.mapping(required=("file", "root", "imu", "feet"),
                 optional=("package_dirs", "hands", "inertias", "visuals", "forward"))

    def path(item: Node) -> Path:
        text = item.string()
        found = Path(text) if Path(text).is_absolute() else config.parent / text
        return found

    file = path(node["file"])
    if not exists(file):
        raise node.error(f"{show(str(file))} does not exist (paths are relative to the robot config)", key="file")
    dirs = tuple(path(item) for item in node["package_dirs"].list()) if node.has("package_dirs") else ()
    imu = node["imu"].mapping(required=("body",), optional=("pos",))
    pos = imu["pos"].vector(3, lo=-SEGMENT_SIZE_M[1], hi=SEGMENT_SIZE_M[1], unit="m") if imu.has("pos") else (0.0, 0.0, 0.0)
    feet = node["feet"].mapping(required=("left", "right"))
    parts = {}
    for side in ("left", "right"):
        foot = feet[side].mapping(required=("body",), optional=("geoms",))
        geoms = tuple(g.string() for g in foot["geoms"].list(1)) if foot.has("geoms") else ()
        parts[side] = ModelFoot(foot["body"].string(), geoms)
    hands = {}
    if node.has("hands"):
        hand_node = node["hands"].mapping(optional=("left", "right"))
        for side in ("left", "right"):
            if hand_node.has(side):
                item = hand_node[side]
                hands[side] = item["body"].string() if isinstance(item.value, dict) else item.string()
    return ModelSource(
        path=file, package_dirs=dirs, root=node["root"].string(), imu_body=imu["body"].string(), imu_pos=tuple(pos),
        feet=parts, hands=hands,
        inertias=node.get("inertias", "as_given").string(("as_given", "from_geometry")),
        drop_visuals=node.get("visuals", "drop").string(("drop", "keep")) == "drop",
        forward=node.get("forward", DEFAULT_FORWARD).string(tuple(FORWARDS)),
    )


def _box(node: Node) -> Box:
    node.mapping(required=("size", "mass"))
    return Box(size=node["size"].vector(3, **SIZE), mass=node["mass"].number(**MASS))


def _read_body(node: Node) -> Body:
    node.mapping(required=("trunk", "pelvis", "hip_spacing", "thigh", "shank", "foot"))
    foot = node["foot"].mapping(
        required=("length", "width", "thickness", "ankle_height", "heel", "mass")
    )
    body = Body(
        trunk=_box(node["trunk"]),
        pelvis=_box(node["pelvis"]),
        hip_spacing=node["hip_spacing"].number(**SIZE),
        thigh=_box(node["thigh"]),
        shank=_box(node["shank"]),
        foot=Foot(**{k: foot[k].number(**(MASS if k == "mass" else SIZE)) for k in Foot.__dataclass_fields__}),
    )
    if body.foot.heel >= body.foot.length:
        raise foot.error("must be shorter than the foot's length", key="heel")
    if body.foot.thickness >= body.foot.ankle_height:
        raise foot.error("must be below ankle_height", key="thickness")
    return body


def _check_derived_body(root: Node, body: Body, preset: str) -> None:
    """A body scaled from anthropometry (whose measures and ratios are checked one by one)
    must still come out plausible: every size and mass within the robot ranges."""
    boxes = {"trunk": body.trunk, "pelvis": body.pelvis, "thigh": body.thigh, "shank": body.shank}
    values = [(f"{name}.size[{i}]", side, SEGMENT_SIZE_M, "m") for name, box in boxes.items()
              for i, side in enumerate(box.size)]
    values += [(f"{name}.mass", box.mass, SEGMENT_MASS_KG, "kg") for name, box in boxes.items()]
    values += [(f"foot.{k}", getattr(body.foot, k), SEGMENT_MASS_KG if k == "mass" else SEGMENT_SIZE_M,
                "kg" if k == "mass" else "m") for k in Foot.__dataclass_fields__]
    values.append(("hip_spacing", body.hip_spacing, SEGMENT_SIZE_M, "m"))
    for what, value, (lo, hi), unit in values:
        if not lo <= value <= hi:
            raise root.error(f"scaled from anthropometry (preset {show(preset)}), {what} is {value:g} {unit}, "
                             f"outside the plausible {lo:g}-{hi:g} {unit}: check its measures, proportions "
                             "and shape", key="body")


def _pd_gains(root: Node) -> Node:
    if not root.has("pd_gains"):
        raise root.error("missing required key 'pd_gains' for actuation: pd", key="pd_gains")
    return root["pd_gains"]


def _refuse_body_keys(root: Node, preset: str | None) -> None:
    """A PD robot from a model file has its body in the file: no box tree, no anthropometry."""
    if preset is not None:
        raise root.error(f"robot has no presets (its body is its model file), got {show(preset)}", key="name")
    for key in ("body", "anthropometry", "proportions", "shape"):
        if root.has(key):
            raise root.error("not with a model: the model file is the body (or give body: and no model:)", key=key)


def _read_pd(node: Node, mass_kg: float | None) -> PDGains:
    """Eq. 2's gains and the torque cap: ``max_torque_nm`` for every body, or
    ``max_torque_nm_per_kg`` times the body's mass [kg] (strength in proportion to size);
    ``mass_kg`` None (a body measured on its model later) keeps the cap per kg.  Optional: a
    servo's speed limit (``no_load_speed_froude``) and one stiffness for every joint in body units
    (``stiffness_mgl``), both checked here and applied by the model builder."""
    node.mapping(required=("kp", "kd"), optional=("max_torque_nm", "max_torque_nm_per_kg", "no_load_speed_froude",
                                                     "stiffness_mgl"))
    caps = [key for key in ("max_torque_nm", "max_torque_nm_per_kg") if node.has(key)]
    if len(caps) != 1:
        raise node.error("give exactly one of max_torque_nm (a fixed cap) and max_torque_nm_per_kg "
                         f"(in proportion to body mass), got {len(caps)}")
    bound = MAX_TORQUE_NM if caps[0] == "max_torque_nm" else MAX_TORQUE_NM_PER_KG
    cap = node[caps[0]].number(positive=True, hi=bound[1], unit="N m" if bound is MAX_TORQUE_NM else "N m/kg")
    if caps[0] == "max_torque_nm":
        fixed, per_kg = cap, None
    elif mass_kg is None:
        fixed, per_kg = None, cap
    else:
        fixed, per_kg = cap * mass_kg, None
    return PDGains(kp=node["kp"].number(positive=True, hi=PD_KP[1], unit="1/s^2"),
                   kd=node["kd"].number(positive=True, hi=PD_KD[1], unit="1/s"),
                   max_torque_nm=fixed, max_torque_nm_per_kg=per_kg,
                   no_load_speed_froude=node["no_load_speed_froude"].number(
                       positive=True, hi=NO_LOAD_SPEED_FROUDE[1], unit="times sqrt(g/leg) rad/s")
                   if node.has("no_load_speed_froude") else None,
                   stiffness_mgl=node["stiffness_mgl"].number(positive=True, hi=STIFFNESS_MGL[1], unit="m g L per rad")
                   if node.has("stiffness_mgl") else None)


def _read_joint(node: Node, servo_robot: bool, default_model: str | None, model_robot: bool = False,
                problems: list[ConfigError] | None = None) -> Joint | None:
    """A joint, or None when its range or servo is wrong: then each such problem is added to
    ``problems`` (with its fix), so that every joint's are listed at once; a malformed entry
    raises."""
    problems = [] if problems is None else problems
    found = len(problems)
    node.mapping(
        required=("name", "location", "axis", "range_deg"), optional=("side", "home_deg", "servo", "sign", "index")
    )
    name = node["name"].string()
    if len(name) > MAX_NAME or not name.isprintable():
        raise node.error(f"a joint name is at most {MAX_NAME} printable characters (it names a MuJoCo joint, "
                         f"a trace column and a controller's input), got {show(name)}", key="name")
    side = node.get("side", "center").string(SIDES)
    location = node["location"].string(LOCATIONS)
    if (location in CENTER_LOCATIONS) != (side == "center"):
        raise node.error(f"{' and '.join(CENTER_LOCATIONS)} joints are side: center, the others (legs, arms) left "
                         f"or right; got a {location} joint on side {side}", key="side")
    sign = 1
    if node.has("sign"):
        if not model_robot:
            raise node.error("a joint's sign relates it to a model file's joint: only for a robot with a model",
                             key="sign")
        sign = node["sign"].integer()
        if sign not in (1, -1):
            raise node.error(f"must be 1 or -1, got {sign}", key="sign")
    index = 0
    if node.has("index"):
        if not model_robot:
            raise node.error("an index orders joints of one role along a model file's chain: only for a robot "
                             "with a model (the box tree has one joint per role)", key="index")
        index = node["index"].integer(0, MAX_INDEX)
    axis = node["axis"].string(AXES)
    if location == "knee" and axis != "pitch":
        raise node.error("a knee is a pitch joint", key="axis")
    lo, hi = node["range_deg"].pair(**ANGLE)
    home = node.get("home_deg", 0.5 * (lo + hi) if not lo <= 0 <= hi else 0.0).number(**ANGLE)
    if not lo <= home <= hi:
        problems.append(node.error(f"{home} deg is outside range_deg [{lo}, {hi}] (fix: a home_deg inside the "
                                   "range, or a wider range_deg)", key="home_deg"))
    servo = None
    if servo_robot:
        if not node.has("servo"):
            raise node.error(f"joint {show(name)} has no servo", key="servo")
        try:
            servo = _read_servo(node["servo"], default_model, (lo, hi))
        except ConfigError as exc:
            problems.append(exc)
    elif node.has("servo"):
        raise node.error("servo blocks are only allowed with actuation: servo", key="servo")
    if len(problems) > found:
        return None
    return Joint(
        name=name,
        side=side,
        location=location,
        axis=axis,
        range_rad=(math.radians(lo), math.radians(hi)),
        home_rad=math.radians(home),
        servo=servo,
        sign=sign,
        index=index,
    )


def _profile(node: Node) -> DeviceProfile:
    try:
        return load_profile(node.string())
    except KeyError as exc:
        raise node.error(exc.args[0]) from None


def _read_servo(node: Node, default_model: str | None, range_deg: tuple[float, float]) -> ServoMap:
    node.mapping(required=("id",), optional=("model", "direction", "zero_offset_deg"))
    if node.has("model"):
        profile = _profile(node["model"])
    elif default_model is None:
        raise node.error("no servo model: set servo.model or the robot's servo_model", key="model")
    else:
        profile = _profile(Node(default_model, node.source, "servo_model"))
    if not profile.is_servo:
        raise node.error(f"{profile.model} is not a servo", key="model")
    direction = node.get("direction", 1).integer()
    if direction not in (1, -1):
        raise node.error(f"must be 1 or -1, got {direction}", key="direction")
    servo = ServoMap(
        id=node["id"].integer(0, 252),
        profile=profile,
        direction=direction,
        zero_offset_rad=math.radians(node.get("zero_offset_deg", 0.0).number(**ANGLE)),
    )
    assert profile.position is not None
    s_lo, s_hi = profile.position.range_rad
    ends = sorted(direction * math.radians(a) + servo.zero_offset_rad for a in range_deg)
    if ends[0] < s_lo - 1e-9 or ends[1] > s_hi + 1e-9:
        fits = sorted(direction * (math.degrees(a) - math.degrees(servo.zero_offset_rad)) for a in (s_lo, s_hi))
        lo, hi = max(range_deg[0], fits[0]), min(range_deg[1], fits[1])
        fix = (f"range_deg [{math.floor(lo * 10 + 1e-6) / 10:g}, {math.floor(hi * 10 + 1e-6) / 10:g}] inside its reach, "
               "a zero_offset_deg that centres it, or a servo model that turns farther") if lo < hi else \
            "a zero_offset_deg that brings the range inside its reach"
        raise node.error(
            f"joint range {list(range_deg)} deg needs servo angles "
            f"[{math.degrees(ends[0]):.1f}, {math.degrees(ends[1]):.1f}] deg, outside the "
            f"{profile.model}'s [{math.degrees(s_lo):.1f}, {math.degrees(s_hi):.1f}] deg (fix: {fix})"
        )
    return servo


def _read_sensor_board(node: Node) -> SensorBoard:
    node.mapping(required=("profile", "id"), optional=("contact_share",))
    profile = _profile(node["profile"])
    if profile.kind != "sensor_board":
        raise node.error(f"{profile.model} is not a sensor board", key="profile")
    share = node["contact_share"].number(positive=True, hi=1.0) if node.has("contact_share") else DEFAULT_CONTACT_SHARE
    return SensorBoard(id=node["id"].integer(0, 252), profile=profile, contact_share=share)


def _read_bus(node: Node) -> BusSettings:
    node.mapping(required=("port", "baud"))
    baud = node["baud"].integer(9600, 10_500_000)
    return BusSettings(port=node["port"].string(), baud=baud)
