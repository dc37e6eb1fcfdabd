"""The locomotion task's parameters (seed 000 sections 8-8.2), typed and validated.

Fitness is the paper's eq. 3, ``f = c_d max(proj_j d, eps) + c_t t`` with d from the start
to the hindmost foot and j the initial facing direction (+x), in leg lengths so that one
setting serves every robot.  Early termination: the waist (pelvis) CoM below 70 % of its
start height (the previous tick's fitness is kept) or - our addition, since a harness holding
the pelvis up hides falls - the torso tilted past ``fall_tilt_deg``; numerical instability (fitness eps),
no progress of eps within ``stagnation_s``.  The support harness holds the pelvis
sideways, from behind and from below - never against forward or upward motion - for the
first ``harness_generations``, weakening linearly over the last ``harness_fade_generations``
of them (an abrupt end would drop every gait that leaned on it at once).

``progress_coeff`` adds a tie-breaker for selection only: the pelvis' forward progress in
leg lengths, so that early generations, which neither step nor fall, are not all equal
(DESIGN.md section 5); the reported fitness stays eq. 3.

When a foot touches is the robot's (its sensor board's ``contact_share``), not the task's:
evolution, the simulated bus and ``compare`` read it there alike.  Configs and controller
files written before carry ``contact_threshold: 0.05``, the value all of them shared; that
key is still read, and refused with any other value.

``phase_period_s: auto`` in a config is the gait clock's period from the robot's leg length
(:func:`gait_period_s`), so that one config serves every robot: the parsed task holds the
number, as a run's ``config.yaml`` and a controller file do.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

from evolve.limits import MAX_EPISODE_S
from sim2real.controller import channels
from sim2real.controller.channels import InputSettings
from sim2real.controller.mapping import OUTPUT_RULES
from sim2real.errors import ConfigError
from sim2real.robot.spec import DEFAULT_CONTACT_SHARE
from sim2real.robot.validation import dataclass_from_mapping, show

# (key, low, high): the value must lie in (low, high]
BOUNDED = (("episode_s", 0.0, MAX_EPISODE_S), ("fall_tilt_deg", 0.0, 180.0), ("stagnation_s", 0.0, float("inf")),
           ("harness_height", 0.0, 1.0))
LEGACY_CONTACT_THRESHOLD = "contact_threshold"  # the task's key for it until the robot owned it


SIGNED = ("reach_forward", "reach_left", "reach_up")  # offsets: either sign
AUTO = "auto"  # phase_period_s: from the robot's leg length
REFERENCE_LEG_M, REFERENCE_PERIOD_S = 0.245, 0.6  # the XL430 biped's leg and its tuned gait clock period


def gait_period_s(leg_length_m: float) -> float:
    """The gait clock's period [s] for a leg of ``leg_length_m`` [m]: the XL430 biped's tuned
    0.6 s scaled by the square root of the leg length (a pendulum's period, dynamic similarity;
    the OP3 recipe's hand-scaled 0.64 s for its 0.279 m leg follows the same rule), to 1 ms."""
    return round(REFERENCE_PERIOD_S * math.sqrt(leg_length_m / REFERENCE_LEG_M), 3)


@dataclass(frozen=True)
class TaskConfig:
    control_set: str = "walk"  # which joints the controller drives (robot's control_sets)
    episode_s: float = 10.0  # simulated seconds per evaluation
    distance_coeff: float = 1.0  # c_d, per leg length walked
    time_coeff: float = 0.3  # c_t, per second upright (10 s upright ~ 3 leg lengths walked)
    epsilon: float = 1e-3  # eps of eq. 3
    fall_height: float = 0.7  # pelvis CoM below this share of its start height ends a trial
    fall_tilt_deg: float = 60.0  # so does a torso tilted this far (a fall the harness hides)
    stagnation_s: float = 3.0  # no progress of epsilon leg lengths in this long ends a trial
    stagnation_progress_leg: float = 0.0  # > 0: the progress [leg lengths] each stagnation_s must see (0: epsilon)
    flight_stop_share: float = 0.0  # > 0: both feet up in more than this share of the episode's ticks ends it, as a fall
    progress_coeff: float = 0.0  # selection tie-breaker: pelvis progress, per leg length
    selection_distance_cap: float = 0.0  # > 0: selection counts distance up to this many leg lengths
    selection_walk_bonus: float = 0.0  # selection adds this for a walk (upright to the end, >= 2.2 leg lengths)
    selection_heading_deg: float = 0.0  # > 0: the bonus only for a walk whose heading stayed this close to the start's
    # selection's per-tick terms for a steady, straight walk (WalkObjective): their weights and kernels
    selection_velocity_coeff: float = 0.0  # times the velocity term: speed along the heading to hold, near the target
    selection_yaw_coeff: float = 0.0  # times the yaw-rate term: turning rate near 0 (or toward the heading to hold)
    selection_speed_leg_s: float = 0.6  # [leg lengths/s] the target speed of the velocity kernel
    selection_yaw_sigma_deg_s: float = 11.5  # [deg/s] the yaw-rate kernel's width (ToddlerBot: exp(-25 e^2), e in rad/s)
    selection_straight_coeff: float = 0.0  # times the straight term: the velocity kernel x the heading kernel
    selection_heading_sigma_deg: float = 15.0  # [deg] the heading kernel's width (the straight term's)
    selection_gait_coeff: float = 0.0  # times the gait term: upright share x hip swing symmetry x the flight kernel
    selection_gait_flight_sigma: float = 0.05  # the flight kernel's width [share of ticks with both feet up]
    selection_smooth_coeff: float = 0.0  # times the smooth term: goals that do not chatter from tick to tick
    selection_smooth_sigma_deg: float = 5.0  # [deg] the smooth kernel's width (RMS of the goals' second difference)
    phase_period_s: float = 0.0  # > 0: the networks get a gait clock of this period [s] (channels.Clock)
    efference_copy: bool = False  # the networks get the goals sent last tick as inputs too (channels.EfferenceCopy)
    heading_input: bool = False  # the networks get the torso's turn since the start (channels.Heading)
    heading_scale_deg: float = channels.Heading.settings[0].default  # [deg] the turn that input reads as 1 (clipped beyond)
    heading_turn_share: float = 0.0  # share of selection's episodes commanded to turn (heading_commands.py)
    heading_turn_max_deg: float = 30.0  # [deg] a commanded turn is drawn within +- this
    gyro_input: bool = False  # the networks get the torso's angular rate (channels.Gyro)
    gyro_scale_dps: float = channels.Gyro.settings[0].default  # [deg/s] the rate that input reads as 1 (clipped beyond)
    # seed 002's reaching (channels.Reach, objective "reach"): the target from the right shoulder
    # [arm lengths], when the hand has reached a goal, and how soon the reach state may toggle
    reach_input: bool = False
    reach_forward: float = channels.REACH.settings[0].default
    reach_left: float = channels.REACH.settings[1].default
    reach_up: float = channels.REACH.settings[2].default
    reach_tolerance: float = channels.REACH.settings[3].default
    reach_phase_s: float = channels.REACH.settings[4].default
    harness_generations: int = 100  # generations with the support harness (0: never)
    harness_fade_generations: int = 50  # over its last this many generations it weakens to nothing
    harness_stiffness: float = 10.0  # harness spring: this many body weights per leg length [m g / L]
    harness_damping: float = 0.5  # harness damping ratio
    harness_height: float = 0.85  # the harness catches the pelvis below this share of its start height
    harness_max_force: float = 0.5  # its force on each axis is capped at this share of the weight
    harness_sideways: float = 1.0  # its sideways spring-damper, times (0: it never holds the robot upright
    #                                sideways, so the lateral weight shift of stepping is learned with it on)
    quantize: bool = True  # joint angles at the servo's encoder resolution
    # an output of 0.5 drives a joint to the middle of its range ("range", seed 000) or to its
    # home angle ("home": linear on each side, for ranges whose home lies near an end)
    output_centre: str = "range"

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any] | None, source: str = "<config>",
                     prefix: str = "task.", leg_length_m: float | None = None) -> "TaskConfig":
        """The task in ``values``; ``leg_length_m`` [m], the robot's, resolves ``phase_period_s: auto``
        (refused without it: a controller file's task always holds the number)."""
        if isinstance(values, Mapping) and values.get("phase_period_s") == AUTO:
            if leg_length_m is None:
                raise ConfigError(source, prefix + "phase_period_s", f"{AUTO!r} needs a robot (its leg length); "
                                  "give the period in seconds")
            values = {**values, "phase_period_s": gait_period_s(leg_length_m)}
        if isinstance(values, Mapping) and LEGACY_CONTACT_THRESHOLD in values:
            values = dict(values)
            legacy = values.pop(LEGACY_CONTACT_THRESHOLD)
            if legacy != DEFAULT_CONTACT_SHARE:
                raise ConfigError(source, prefix + LEGACY_CONTACT_THRESHOLD, f"{show(legacy)}: when a foot touches is "
                                  "the robot's now (sensor_board.contact_share in its config, default "
                                  f"{DEFAULT_CONTACT_SHARE}), read alike by evolution, the simulated bus and "
                                  "compare; remove this key")
        config = dataclass_from_mapping(cls, values, source, prefix, "task")
        for f in dataclasses.fields(config):
            v = getattr(config, f.name)
            if isinstance(v, float) and not math.isfinite(v):  # a controller file holds the task
                raise ConfigError(source, prefix + f.name, f"must be finite, got {v}")
            if isinstance(v, (int, float)) and not isinstance(v, bool) and v < 0 and f.name not in SIGNED:
                raise ConfigError(source, prefix + f.name, f"must not be negative, got {v}")
        if config.episode_s <= 0:
            raise ConfigError(source, prefix + "episode_s", "must be > 0")
        for key, lo, hi in BOUNDED:
            v = getattr(config, key)
            if not lo < v <= hi:
                bound = f"> {lo:g}" if hi == float("inf") else f"within ({lo:g}, {hi:g}]"
                raise ConfigError(source, prefix + key, f"must be {bound}, got {v:g}")
        if config.selection_heading_deg and not (config.selection_walk_bonus and config.selection_heading_deg < 180):
            raise ConfigError(source, prefix + "selection_heading_deg", "limits which walks earn "
                              "selection_walk_bonus: give the bonus too, and less than 180 deg")
        _check_input_settings(config, source, prefix)
        if not config.heading_turn_share <= 1:
            raise ConfigError(source, prefix + "heading_turn_share", f"is a share (0-1), got {config.heading_turn_share:g}")
        if config.heading_turn_share and not config.heading_input:
            raise ConfigError(source, prefix + "heading_turn_share", "commands a heading to hold: give heading_input: true")
        if not 0 < config.heading_turn_max_deg <= 180:
            raise ConfigError(source, prefix + "heading_turn_max_deg", f"must be within (0, 180], got "
                              f"{config.heading_turn_max_deg:g}")
        for key in ("selection_speed_leg_s", "selection_yaw_sigma_deg_s", "selection_heading_sigma_deg",
                    "selection_gait_flight_sigma", "selection_smooth_sigma_deg"):
            if not getattr(config, key) > 0:
                raise ConfigError(source, prefix + key, f"must be > 0, got {getattr(config, key):g}")
        if config.output_centre not in OUTPUT_RULES:
            raise ConfigError(source, prefix + "output_centre", f"must be one of {', '.join(OUTPUT_RULES)}, got "
                              f"{show(config.output_centre)}")
        if not 0 <= config.flight_stop_share < 1:
            raise ConfigError(source, prefix + "flight_stop_share", f"is a share of the ticks, within [0, 1) (0: off), "
                              f"got {config.flight_stop_share:g}")
        if not 0 < config.fall_height < 1:
            raise ConfigError(source, prefix + "fall_height", "must be within (0, 1)")
        return config

    def harness_strength(self, generation: int) -> float:
        """1 while the harness is on in full, falling linearly to 0 at ``harness_generations``."""
        if generation >= self.harness_generations:
            return 0.0
        fade_start = self.harness_generations - self.harness_fade_generations
        if generation < fade_start or self.harness_fade_generations == 0:
            return 1.0
        return (self.harness_generations - generation) / (self.harness_fade_generations + 1)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @property
    def inputs(self) -> InputSettings:
        """The optional input channels on, with their settings (:func:`channels.selection`)."""
        return channels.selection(self.to_dict())


def _check_input_settings(config: TaskConfig, source: str, prefix: str) -> None:
    """Each input channel's settings within the controller format's bounds, and given only
    with their channel on (a clock's period of 0 is the clock off)."""
    chosen = config.inputs
    for channel in channels.CHANNELS:
        for setting in channel.settings:
            value = getattr(config, setting.key)
            if channel.switch is None and value == 0:  # the setting that switches it: 0 is off
                continue
            if channel.key not in chosen:
                if value != setting.default:
                    raise ConfigError(source, prefix + setting.key, f"is the {channel.key} input's setting: give it "
                                      f"only with {channel.switch}: true")
                continue
            if not setting.admits(value):
                off = f"0 (no {channel.key}) or " if channel.switch is None else ""
                raise ConfigError(source, prefix + setting.key, f"must be {off}within {setting.bounds}, got {value:g}")
