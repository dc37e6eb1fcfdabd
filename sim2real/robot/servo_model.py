"""A Dynamixel in position mode as MuJoCo joint and actuator parameters.

The servo is a proportional position loop driving a geared DC motor (the M1 model of
Rhoban's BAM).  The firmware's control law and the motor's physics stay apart:

* firmware: duty = clip(KPP * e_ticks / pwm_limit, -1, 1), with KPP = P / 128 on the
  X series, so the commanded torque is ``kp * e`` with ``kp = stall * KPP * ticks_per_rad
  / pwm_limit`` [N m/rad], saturating at the stall torque (a MuJoCo ``position``
  actuator with ``forcerange = +-stall``);
* motor: back-EMF and viscous friction act as joint damping outside that saturation,
  Coulomb friction as ``frictionloss``, the rotor's reflected inertia as ``armature``.

The damping is chosen so that a servo at full duty and no load turns at the datasheet's
no-load speed: ``stall - coulomb - damping * w0 = 0``.  The datasheet's no-load speed is
measured with the gearbox's own friction, so this reproduces it exactly, and the back-EMF
part is what remains after the identified viscous friction.

The I term defaults to 0 and is left out.  The D term (KPD = D/16 PWM units per tick of
error change in one loop period) is a velocity gain inside the torque limit, ``kv = kp *
Td`` with the derivative time ``Td = (KPD / KPP) * loop period`` (:func:`derivative_time`);
the e-manual does not publish the loop period, so the nominal model leaves the D term out
and reality files draw ``Td`` (``derivative_ms``; docs/servo_model.md).  The AX-12A's
compliance slope is a proportional band: torque rises from 0 to the torque limit over
``slope`` ticks.

Gear backlash is not a servo parameter here: it is a joint of the model
(:mod:`sim2real.simulation.model.builder`), its width drawn by reality files.
"""

from __future__ import annotations

from dataclasses import dataclass

from sim2real.robot.profiles import DeviceProfile


@dataclass(frozen=True)
class ServoPhysics:
    """Per-joint MuJoCo parameters of one servo model (output-shaft side)."""

    kp: float  # position gain [N m/rad]
    force_limit: float  # stall torque [N m]
    damping: float  # back-EMF + viscous [N m s/rad]
    frictionloss: float  # Coulomb friction [N m]
    armature: float  # reflected rotor inertia [kg m^2]
    no_load_speed: float  # [rad/s]
    rad_per_tick: float  # encoder resolution [rad]


def position_gain(profile: DeviceProfile) -> float:
    """Proportional gain of the firmware's position loop at default gains [N m/rad]."""
    assert profile.position is not None and profile.motor is not None and profile.gains
    ticks_per_rad = 1.0 / profile.position.rad_per_tick
    stall = profile.motor.stall_torque_nm
    g = profile.gains.values
    if profile.gains.type == "pid":
        kpp = g["position_p"] / g["p_divisor"]  # [PWM units / tick]
        return stall * kpp * ticks_per_rad / g["pwm_limit"]
    # compliance: full torque limit reached `slope` ticks away from the goal
    slope = 0.5 * (g["cw_compliance_slope"] + g["ccw_compliance_slope"])
    return stall * (g["torque_limit"] / 1023.0) / (slope / ticks_per_rad)


def derivative_time(profile: DeviceProfile, loop_hz: float) -> float:
    """The D term's derivative time ``Td`` (kv = kp * Td) at a firmware loop rate [s]: KPD
    acts on the error's change over one loop period, KPP on the error."""
    assert profile.gains is not None
    g = profile.gains.values
    if profile.gains.type != "pid" or not g["position_p"]:
        return 0.0
    kpd, kpp = g["position_d"] / g["d_divisor"], g["position_p"] / g["p_divisor"]
    return kpd / kpp / loop_hz


def servo_physics(profile: DeviceProfile) -> ServoPhysics:
    """MuJoCo joint and actuator parameters for a servo profile."""
    if not profile.is_servo or profile.motor is None or profile.position is None:
        raise ValueError(f"{profile.model} is not a servo profile")
    motor = profile.motor
    w0 = motor.no_load_speed_rad_s
    damping = (motor.stall_torque_nm - motor.coulomb_friction_nm) / w0
    if damping < motor.viscous_friction_nms:
        raise ValueError(
            f"{profile.path}: motor.viscous_friction_nms is too large to reach the no-load speed"
        )
    return ServoPhysics(
        kp=position_gain(profile),
        force_limit=motor.stall_torque_nm,
        damping=damping,
        frictionloss=motor.coulomb_friction_nm,
        armature=motor.armature_kgm2,
        no_load_speed=w0,
        rad_per_tick=profile.position.rad_per_tick,
    )


def max_step_per_tick(profile: DeviceProfile, tick_s: float) -> float:
    """How far a goal may move in one control tick: the no-load speed times the tick [rad]."""
    assert profile.motor is not None
    return profile.motor.no_load_speed_rad_s * tick_s
