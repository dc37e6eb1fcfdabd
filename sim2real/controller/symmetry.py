"""Bilateral symmetry (seed 000 section 7.3): one genome, two networks, one per side.

Each network reads its side's view of the robot and drives its side's joints:

* inputs: the driven joint angles of its own leg, then of the other leg, then of the centre
  (waist) joints, each normalized to [-1, 1] over the joint's range; the foot contacts,
  own foot first (-1 touching, +1 not); the torso's tilt forward and toward the network's
  own side, from the up-vector as an IMU measures it (world up in the torso frame: x
  forward, y left, z up).  Joint angles are anatomical, so the two legs already read alike;
  the sideways tilt and the waist's yaw and roll are mirrored for the left network.  With
  the walk preset of a biped with a waist, that is seed 000's eleven inputs.  The paper
  names its tilt inputs X and Z: the horizontal components of the up-vector in its y-up
  world, which are forward and sideways here.
* optionally the torso's heading (``heading``): how far it has turned since the start
  toward the network's own side, in half turns or on a smaller scale (:func:`heading_input`),
  from the board's heading (an IMU's yaw).  The up-vector does not change when the robot
  yaws, so without it a network cannot tell that it is turning, and a walker that turns a
  little on the model may walk back on a robot a little off it (``benchmarks/RESULTS.md``,
  "Heading").
* optionally the torso's angular rate (``gyro_roll``, ``gyro_pitch``, ``gyro_yaw``): a gyro's
  rates about the torso's x, y and z axes over a scale, clipped to [-1, 1]; the left network
  reads roll and yaw rate negated (odd under the mirror) and pitch rate as it is.  Without it
  a network senses rotation only once it has tilted or turned.
* optionally a clock (``phase_sin``, ``phase_cos``): the sine and cosine of the gait phase
  ``2 pi t / period``, the left network's half a period later (both negated), so that one
  genome's two networks step in antiphase.  A recurrent network then need not find its own
  oscillator: the rhythm is the clock's, whatever the body, and evolution tunes the feedback.
* optionally an efference copy (a joint input's name and ``_goal``): the goals sent last tick, own leg,
  other leg and centre as the joint angles are (normalized, mirrored alike), after the clock
  - so that a network can tell what it asked for from what the servos did (Open Duck Mini
  feeds its last actions back the same way).
* optionally seed 002's reach control (``reach_control``, ``target_forward``, ``target_left``,
  ``target_up``): 1 while the right hand reaches, and the target from the right shoulder;
  the left network reads zeros - a one-handed task told to one copy only.
* two bias nodes (:data:`BIAS`): +1, and +1 on the right, -1 on the left.
* outputs: its own leg's driven joints, then the centre joints; a centre joint gets the
  mean of the two networks' outputs (activations, as the paper says).

Each input is a channel of :mod:`sim2real.controller.channels`, which owns the order, the
names, the mirroring and the computation for evolution and the runtime alike; here are the
layout (which joints each network reads and drives) and the plain reference of the inputs.

Networks are interleaved: row ``2 i`` is genome ``i``'s right network, ``2 i + 1`` its left.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim2real.controller import channels
from sim2real.controller.channels import InputSettings, turn_rad
from sim2real.robot import RobotSpec

SIDES = ("right", "left")


BIAS = ((1.0, 1.0), (1.0, -1.0))  # the bias nodes of the (right, left) network: +1, and the side
SIDE_BIAS = next(i for i, (right, left) in enumerate(zip(*BIAS)) if right != left)  # which of them is the side's
CENTER_OUTPUT = "mean of both networks"  # what a centre joint gets


HEADING_SCALE_DEG = channels.Heading.settings[0].default  # [deg] the turn that reads 1 by default: half turns


def heading_input(heading_rad: np.ndarray | float, start_rad: np.ndarray | float,
                  scale_deg: float = HEADING_SCALE_DEG) -> np.ndarray:
    """The right network's heading input: :func:`turn_rad` over ``-scale_deg``, clipped to
    [-1, 1] - turning right (toward the right network's own side) is positive, and a turn of
    ``scale_deg`` or more reads +-1.  The default reads half turns (facing back is +-1); a
    smaller scale makes the turns a walk must correct (tens of degrees) inputs of the size of
    the others, which fixed-variance weight mutation can use."""
    return np.clip(-turn_rad(heading_rad, start_rad) / np.radians(scale_deg), -1.0, 1.0)


def phase_inputs(t_s: np.ndarray | float, period_s: float) -> np.ndarray:
    """The right network's clock inputs at times ``t_s`` [s] since the start: (..., 2)
    ``[sin, cos]`` of ``2 pi t / period``."""
    angle = 2.0 * np.pi * np.asarray(t_s, dtype=float) / period_s
    return np.stack([np.sin(angle), np.cos(angle)], axis=-1)


@dataclass(frozen=True, eq=False)
class SymmetricLayout:
    driven: tuple[str, ...]  # driven joints, robot order
    leg_slots: tuple[tuple[str, str, int], ...]  # (location, axis, index) of each driven leg joint kind
    leg_index: dict[str, np.ndarray]  # side -> robot joint index of each slot
    center_index: np.ndarray  # robot joint index of each driven centre joint
    center_mirror: np.ndarray  # -1 where the left network sees the joint mirrored (yaw, roll)
    inputs: InputSettings  # the optional input channels on, with their settings (sim2real.controller.channels)
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]

    n_bias = len(BIAS[0])

    @property
    def n_inputs(self) -> int:
        return len(self.input_names)

    @property
    def n_outputs(self) -> int:
        return len(self.output_names)

    @property
    def n_leg(self) -> int:
        return len(self.leg_slots)

    @property
    def efference(self) -> bool:
        return "efference" in self.inputs

    @property
    def heading(self) -> bool:
        return "heading" in self.inputs

    @property
    def gyro(self) -> bool:
        return "gyro" in self.inputs

    @property
    def reach(self) -> bool:
        return "reach" in self.inputs

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, SymmetricLayout):
            return NotImplemented
        return (self.driven == other.driven and self.leg_slots == other.leg_slots
                and {k: dict(v) for k, v in self.inputs.items()} == {k: dict(v) for k, v in other.inputs.items()}
                and self.input_names == other.input_names and self.output_names == other.output_names
                and all(np.array_equal(self.leg_index[s], other.leg_index[s]) for s in SIDES)
                and np.array_equal(self.center_index, other.center_index)
                and np.array_equal(self.center_mirror, other.center_mirror))


def symmetric_layout(robot: RobotSpec, driven: tuple[str, ...], inputs: InputSettings | None = None) -> SymmetricLayout:
    """The wiring the rule gives for ``driven`` joints: leg slots in robot order, both sides
    of each; centre joints in robot order, yaw and roll mirrored for the left network; the
    optional input channels ``inputs`` (:func:`sim2real.controller.channels.selection`) after
    the sensors, in the registry's order."""
    joints = {j.name: j for j in robot.joints}
    unknown = [n for n in driven if n not in joints]
    if unknown:
        raise ValueError(f"driven joints not on robot {robot.name}: {unknown}")
    order = {j.name: i for i, j in enumerate(robot.joints)}
    slots: list[tuple[str, str, int]] = []
    for name in sorted(driven, key=order.get):
        j = joints[name]
        if j.side != "center" and j.slot not in slots:
            slots.append(j.slot)
    by_slot = {(j.side, *j.slot): j.name for j in robot.joints}
    legs = {}
    for side in SIDES:
        names = []
        for slot in slots:
            name = by_slot[(side, *slot)]
            if name not in driven:
                raise ValueError(f"driven joints must be symmetric: {name} is missing")
            names.append(name)
        legs[side] = tuple(names)
    centers = tuple(n for n in sorted(driven, key=order.get) if joints[n].side == "center")
    mirror = tuple(-1.0 if joints[n].axis in ("yaw", "roll") else 1.0 for n in centers)
    return wired_layout(robot, legs["right"], legs["left"], centers, mirror, inputs)


def wired_layout(robot: RobotSpec, right: tuple[str, ...], left: tuple[str, ...], center: tuple[str, ...],
                 center_mirror: tuple[float, ...], inputs: InputSettings | None = None) -> SymmetricLayout:
    """The layout of given wiring - a controller file's symmetry block: each side's leg
    joints slot by slot, the centre joints and their mirror signs for the left network."""
    order = {j.name: i for i, j in enumerate(robot.joints)}
    unknown = [n for n in (*right, *left, *center) if n not in order]
    if unknown:
        raise ValueError(f"joints not on robot {robot.name}: {unknown}")
    slots = tuple(robot.joints[order[n]].slot for n in right)
    settings = {key: dict(value) for key, value in (inputs or {}).items()}
    angles = channels.angle_names(slots, center)
    return SymmetricLayout(
        driven=tuple(sorted((*right, *left, *center), key=order.get)),
        leg_slots=slots,
        leg_index={side: np.array([order[n] for n in names], dtype=np.intp)
                   for side, names in (("right", right), ("left", left))},
        center_index=np.array([order[n] for n in center], dtype=np.intp),
        center_mirror=np.array(center_mirror, dtype=float),
        inputs=settings,
        input_names=channels.input_names(angles, settings),  # unknown channels refused here
        output_names=tuple(angles[:len(slots)] + list(center)),
    )


def network_inputs(layout: SymmetricLayout, joints: np.ndarray, feet: np.ndarray,
                   up: np.ndarray, phase: np.ndarray | None = None, goals: np.ndarray | None = None,
                   heading: np.ndarray | None = None, gyro: np.ndarray | None = None,
                   reach: np.ndarray | None = None) -> np.ndarray:
    """Inputs of both networks of every robot, side by side and name by name: the plain
    reference (test oracle) of :meth:`sim2real.controller.channels.InputWiring.inputs`,
    which evolution and the runtime run.

    Args:
      joints: (n, n_joints) normalized joint angles in robot order, in [-1, 1].
      feet: (n, 2) foot contacts, columns (left, right): -1 touching, +1 not.
      up: (n, 3) world up in the torso frame (an IMU's normalized gravity, negated).
      phase: (n, 2) the right network's clock (:func:`phase_inputs`), if the layout has one.
      goals: (n, n_joints) the goals sent last tick, normalized as ``joints``, if the layout
        has an efference copy.
      heading: (n,) the right network's heading input (:func:`heading_input`), if the layout
        has one.
      gyro: (n, 3) the torso's angular rate over the layout's scale, clipped to [-1, 1]
        (roll, pitch, yaw: about x forward, y left, z up), if the layout reads it.
      reach: (n, 4) the reach state (1 reaching, 0 returning) and the target's offset from the
        right shoulder [arm lengths], if the layout reads them: the right network's; the left
        network reads zeros.

    Returns:
      (2 n, n_inputs), rows interleaved right, left.
    """
    for given, (key, what) in ((phase, ("clock", "the phase")), (goals, ("efference", "the last goals")),
                               (heading, ("heading", "the heading")), (gyro, ("gyro", "the gyro")),
                               (reach, ("reach", "the reach state"))):
        if (key in layout.inputs) != (given is not None):
            raise ValueError(f"{what} given to a layout without that input" if given is not None
                             else f"this layout reads {what}: give {what}")
    n = joints.shape[0]
    out = np.empty((n, 2, len(layout.input_names)))
    for s, (own_foot, other_foot, side_sign) in enumerate(((feet[:, 1], feet[:, 0], 1.0),
                                                           (feet[:, 0], feet[:, 1], -1.0))):
        value = dict(zip(layout.input_names, _angle_inputs(layout, joints, s).T))
        if goals is not None:
            angle_names = layout.input_names[:2 * layout.n_leg + len(layout.center_index)]
            value.update(zip((name + "_goal" for name in angle_names), _angle_inputs(layout, goals, s).T))
        value["own_foot"], value["other_foot"] = own_foot, other_foot
        value["up_forward"] = -up[:, 0]  # leaning forward is positive
        # leaning toward the network's own side is positive on both sides (leaning right
        # tilts world up toward the torso's +y)
        value["up_sideways"] = up[:, 1] * side_sign
        if heading is not None:
            value["heading"] = heading * side_sign  # turning toward the network's own side is positive
        if gyro is not None:  # roll and yaw rate are odd under the mirror, pitch rate even
            value["gyro_roll"], value["gyro_pitch"], value["gyro_yaw"] = \
                gyro[:, 0] * side_sign, gyro[:, 1], gyro[:, 2] * side_sign
        if phase is not None:
            value["phase_sin"], value["phase_cos"] = phase[:, 0] * side_sign, phase[:, 1] * side_sign
        if reach is not None:  # only the right hand reaches: the right network reads the state and target
            state = reach[:, 0] if s == 0 else np.zeros(n)
            target = reach[:, 1:] * state[:, None] if s == 0 else np.zeros((n, 3))
            value["reach_control"] = state
            value["target_forward"], value["target_left"], value["target_up"] = target.T
        out[:, s] = np.stack([value[name] for name in layout.input_names], axis=1)
    return out.reshape(2 * n, -1)


def _angle_inputs(layout: SymmetricLayout, angles: np.ndarray, side: int) -> np.ndarray:
    """(n, 2 k + centre) the inputs of network ``side`` (0 right, 1 left) read from joint
    values in robot order: own leg, other leg, centre (mirrored for the left network)."""
    own, other = (layout.leg_index["right"], layout.leg_index["left"])[::1 if side == 0 else -1]
    mirror = 1.0 if side == 0 else layout.center_mirror
    return np.concatenate([angles[:, own], angles[:, other], angles[:, layout.center_index] * mirror], axis=1)


def bias_values(n_genomes: int) -> np.ndarray:
    """(2 n, 2): :data:`BIAS` for each genome's right and left network."""
    return np.tile(np.array(BIAS), (n_genomes, 1))


def joint_outputs(layout: SymmetricLayout, outputs: np.ndarray, n_joints: int) -> np.ndarray:
    """(2 n, n_outputs) network outputs -> (n, n_joints) outputs in robot order (NaN where
    not driven); centre joints get the mean of both networks."""
    pair = outputs.reshape(-1, 2, outputs.shape[1])
    n = pair.shape[0]
    result = np.full((n, n_joints), np.nan)
    k = layout.n_leg
    result[:, layout.leg_index["right"]] = pair[:, 0, :k]
    result[:, layout.leg_index["left"]] = pair[:, 1, :k]
    result[:, layout.center_index] = pair[:, :, k:].mean(axis=1)
    return result
