"""System identification: fit the servo model to a robot's own traces (``biped sysid``).

The traces come from ``biped excite`` (chirps and steps, the robot hung by its pelvis): goals
in, encoder angles out.  The fit replays each trace's goals in the hung model (with backlash
joints) and moves the servo parameters until the simulated encoder angles match the
recorded ones, in the least-squares sense - through ``mujoco.sysid``: its parameters with
bounds, rollouts, the optimizer (MuJoCo's own bounded Levenberg-Marquardt with
finite-difference Jacobians), confidence intervals and HTML report.  Goals act from the
physics step nearest their row's time, quantized as the servo received them; each segment's
settling lead is not compared.

What is fitted, per servo model (or per joint), in the vocabulary of reality files
(:mod:`sim2real.simulation.reality.file`): ``kp_scale`` (position gain), ``torque_scale`` (stall
torque), ``damping_scale`` (back-EMF damping), ``friction_scale`` (Coulomb friction),
``armature_scale`` (rotor inertia), ``backlash_deg`` (gear play, full width); and for the
whole bus ``latency_ms``, from a goal's row in the trace to the servo acting on it: the
robot's own latency plus the bus's transport.  Latency is a delay of the whole response
(``SignalTransform``-style resampling of the prediction), exact for a hung robot, whose
response does not feed back into its goals.

Each trace is cut into its excitation segments (chirps, steps; from the sidecar), each
replayed from rest at its measured angles, so that rollouts are short and parallel.  A
parameter whose confidence interval covers much of its range (or is infinite) is reported
*not identifiable* from these traces: the traces do not excite what it does.
"""

from __future__ import annotations

import copy
import dataclasses
import io
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import mujoco
import numpy as np

from sim2real.atomic_json import write_text_atomic
from sim2real.controller.mapping import ServoMapping
from sim2real.errors import ConfigError
from sim2real.hardware.trace import Trace, check_joint_angles, sidecar_path
from sim2real.input_files import refuse_repeats
from sim2real.robot import RobotSpec
from sim2real.robot.validation import show
from sim2real.simulation.model.builder import finished_spec
from sim2real.simulation.model.robot_model import JointAngles, joint_sensor
from sim2real.simulation.reality.file import NOMINAL
from sim2real.simulation.reality.randomize import Perturbation, apply_to_model, sample

# fitted per group: (reality key, low, high)
SERVO_PARAMETERS = (
    ("kp_scale", 0.3, 3.0),
    ("torque_scale", 0.3, 2.0),
    ("damping_scale", 0.1, 5.0),
    ("friction_scale", 0.05, 5.0),
    ("armature_scale", 0.1, 5.0),
    ("backlash_deg", 0.0, 2.0),
)
LATENCY = ("latency_ms", 0.0, 60.0)  # one for the bus
LATENCY_START_MS = 5.0  # where the fit starts it: off its bound (and play off its bound of 0, likewise)
MIN_SECONDS = 2.0  # a trace shorter than this cannot show a servo's dynamics
MIN_EXCITATION_DEG = 0.5  # a trace whose goals move less than this (peak to peak) excites nothing
LEAD_S = 0.25  # each segment is replayed from this long before it (the robot at rest, holding)
MIN_SEGMENT_ROWS = 10  # a segment cut shorter than this (a trace stopped early) is left out
# finite-difference step of the Jacobian (mujoco.minimize: this times max(1, |x|)): a smaller
# step follows the kinks of friction, saturation and play.  Measured on a simulated-clock trace
# of plain_weak's robot: 1e-2 stalled at cost 38.3 (the truth's is 31.9, with a descent toward
# it left), 3e-2 and 1e-1 went below the truth's (27.4, 27.2); on the real-time bus 1e-1 fitted
# in 7 iterations what 1e-2 did in 30, closer to the truth (benchmarks/RESULTS.md, issue 15)
FD_STEP = 1e-1
UNIDENTIFIABLE_SHARE = 0.5  # a 95 % interval wider than this share of the bounds: not identifiable


@dataclass(frozen=True)
class Segment:
    """A stretch of one trace replayed on its own: rows ``start:end``."""

    trace: int
    name: str
    start: int
    end: int
    joints: tuple[str, ...] = ()  # the joints it moves (empty: unknown, all of them)


def check_traces(paths: Sequence[Path | str], robot: RobotSpec, warn: Callable[[str], None] = print) -> list[Trace]:
    """Read the traces and refuse, one line each, what cannot be fitted: another robot's
    trace, one without the robot's joints or with angles it cannot take, too short, without
    excitation, or not of the hung robot - including every trace whose sidecar does not say
    how the robot was held (a `biped run` trace of a walk: the model is fitted hung, and
    a walking robot's joints carry its weight and hit the floor, so its servo parameters
    would come out wrong, with nothing to say so)."""
    refuse_repeats(paths, "trace")  # fitted twice, its segments would weigh double
    traces = []
    for path in paths:
        trace = Trace.read(path)  # refuses NaNs, text that is not a trace; notes a cut last row and gaps
        for note in trace.notes:
            warn(f"warning: {note}")
        source = str(path)
        made_for = trace.metadata.get("robot")
        if made_for is not None and made_for != robot.name:
            raise ConfigError(source, "robot", f"a trace of robot {show(made_for)}, not {robot.name!r} (use --robot)")
        missing = trace.missing([f"{j}_{kind}_rad" for j in robot.joint_names for kind in ("goal", "present")])
        if missing:
            raise ConfigError(source, "header", f"lacks {len(missing)} channel(s) of robot {robot.name}, "
                              f"e.g. {missing[0]!r}: a trace of another robot?")
        check_joint_angles(trace, [(j.name, j.range_rad) for j in robot.joints], source)
        if trace.times[-1] - trace.times[0] < MIN_SECONDS:
            raise ConfigError(source, "", f"too short to fit: {trace.times[-1] - trace.times[0]:.2f} s "
                              f"(at least {MIN_SECONDS:g} s; `biped excite` records about 2 minutes)")
        moved = np.degrees(np.ptp(trace.goals(robot.joint_names), axis=0))
        if moved.max() < MIN_EXCITATION_DEG:
            raise ConfigError(source, "", f"no excitation: no goal moves more than {moved.max():.2f} deg "
                              "(record one with `biped excite`)")
        excitation = trace.metadata.get("excitation")
        pose = excitation.get("pose") if isinstance(excitation, dict) else None
        if pose is None:
            raise ConfigError(source, "excitation.pose", "not a `biped excite` trace: its sidecar does not say that "
                              "the robot hung by its pelvis, and the fit replays it on the hung model (a walk's "
                              "joints carry the weight and meet the floor: fitted as hung, the servo parameters "
                              "would come out wrong). Record one with `biped excite`; compare a walk with "
                              "`biped compare`")
        _check_segments(excitation.get("segments", []), str(sidecar_path(source)))
        if pose != "suspended":
            raise ConfigError(source, "excitation.pose", f"{pose!r}: only traces of the hung robot "
                              "(`biped excite --pose suspended`) can be fitted: standing, the trunk's "
                              "position and speed are not measured, so no replay can start where the "
                              "robot was (use a standing trace with `biped compare`)")
        traces.append(trace)
    return traces


def _check_segments(parts: Any, source: str) -> None:
    """The sidecar's excitation segments as `biped excite` writes them: {group, kind, joints,
    start, end} with whole ticks, start before end, each joint a name."""
    if not isinstance(parts, list):
        raise ConfigError(source, "excitation.segments", "must be a list of segments")
    for i, part in enumerate(parts):
        ok = (isinstance(part, dict) and all(isinstance(part.get(k), str) for k in ("group", "kind"))
              and all(type(part.get(k)) is int and part[k] >= 0 for k in ("start", "end"))
              and part["start"] < part["end"]
              and isinstance(part.get("joints", []), list) and all(isinstance(j, str) for j in part.get("joints", [])))
        if not ok:
            raise ConfigError(source, f"excitation.segments[{i}]", "must be {group, kind, joints, start, end} with "
                              "0 <= start < end in ticks, as `biped excite` writes it")


def segments(traces: Sequence[Trace]) -> list[Segment]:
    """The excitation segments of each trace (its sidecar's), from ``LEAD_S`` before each;
    a trace without them is one segment."""
    out = []
    for i, trace in enumerate(traces):
        parts = trace.metadata.get("excitation", {}).get("segments") or []
        ticks = trace["tick"] if "tick" in trace else np.arange(len(trace))
        tick_s = float(np.median(np.diff(trace.times)))
        for part in parts:
            lead = int(round(LEAD_S / tick_s))
            start = int(np.searchsorted(ticks, part["start"] - lead))
            end = int(np.searchsorted(ticks, part["end"] + lead))
            if end - start >= MIN_SEGMENT_ROWS:
                out.append(Segment(i, f"{part['group']} {part['kind']}", start, min(end, len(trace)),
                                   tuple(part.get("joints", ()))))
        if not parts:
            out.append(Segment(i, f"trace {i}", 0, len(trace)))
    return out


class Fit:
    """The model, the data and the parameters of one identification."""

    def __init__(self, robot: RobotSpec, traces: Sequence[Trace], per_joint: bool = False):
        from mujoco import sysid

        self.robot, self.traces = robot, list(traces)
        self.joints = list(robot.joint_names)
        # the spec is mujoco.sysid's bookkeeping (sensor names, a reference model); every
        # fitted model comes from `build`, the nominal one perturbed as a reality file would
        self.spec = finished_spec(robot, backlash=True, suspended=True)
        self.model = self.spec.compile()
        self.nominal = copy.copy(self.model)
        self.unperturbed = sample(NOMINAL, np.zeros((1, 1)), self.nominal, 0, 1.0)  # what each fitted value replaces
        self.angles = JointAngles.of(self.model, self.joints)
        self.dt = self.model.opt.timestep
        self.mapping = ServoMapping(robot)
        self.groups: dict[str, list[int]] = {}  # what one set of parameters covers: joint indices
        if per_joint:
            self.groups = {name: [k] for k, name in enumerate(self.joints)}
        else:
            for k, joint in enumerate(robot.joints):
                key = joint.servo.profile.model if joint.servo else "servo-less"
                self.groups.setdefault(key, []).append(k)
        self.params = sysid.ParameterDict()
        for group in self.groups:
            for key, low, high in SERVO_PARAMETERS:
                nominal = NOMINAL.range(key)[0]
                start = max(nominal, low + 0.05 * (high - low)) if key == "backlash_deg" else nominal
                self.params.add(sysid.Parameter(self.name(group, key), nominal=start, min_value=low, max_value=high))
        key, low, high = LATENCY
        self.params.add(sysid.Parameter(key, nominal=LATENCY_START_MS, min_value=low, max_value=high))
        self.segments = segments(self.traces)
        from absl import logging as absl_logging  # mujoco.sysid's logger

        verbosity = absl_logging.get_verbosity()
        absl_logging.set_verbosity(absl_logging.ERROR)  # it warns, per segment, of sensors not recorded: expected
        try:
            self.sequences = [self._sequence(s) for s in self.segments]
        finally:
            absl_logging.set_verbosity(verbosity)

    @staticmethod
    def name(group: str, key: str) -> str:
        return f"{group}/{key}"

    def nominal_params(self):
        """The parameters of the nominal model (no play, no latency; the fit starts a little
        off those two, away from their bounds)."""
        params = self.params.copy()
        for name, p in params.items():
            p.value[:] = NOMINAL.range(name.split("/")[-1])[0]
        return params

    # -- the model for a parameter vector --------------------------------------------------------
    def perturbation(self, params) -> Perturbation:
        """The fitted values as a reality perturbation (one row), so that the model is
        perturbed exactly as evolution and the simulated bus perturb theirs."""
        fields = {}
        for key, *_ in SERVO_PARAMETERS:
            column = np.zeros(len(self.joints))
            for group, members in self.groups.items():
                column[members] = params[self.name(group, key)].value[0]
            fields["backlash_rad" if key == "backlash_deg" else key] = (
                np.radians(column) if key == "backlash_deg" else column)[None]
        return dataclasses.replace(self.unperturbed, **fields)

    def build(self, params, spec=None) -> mujoco.MjModel:
        model = copy.copy(self.nominal)
        apply_to_model(model, self.nominal, self.perturbation(params))
        return model

    # -- data --------------------------------------------------------------------------------------
    def _sequence(self, seg: Segment):
        """A segment as ``mujoco.sysid`` data: goals held between rows (zero-order, as a servo
        holds its goal) at the physics step, encoder angles at the rows' times."""
        from mujoco import sysid

        trace = self.traces[seg.trace]
        t = trace.times[seg.start:seg.end] - trace.times[seg.start]
        goals = self.mapping.angles(self.mapping.ticks(trace.goals(self.joints)[seg.start:seg.end]))  # as sent
        present = trace.present(self.joints)[seg.start:seg.end]
        steps = np.arange(int(t[-1] / self.dt) + 1) * self.dt
        # a goal acts from the physics step nearest its row's time: rounding, not flooring, or
        # every goal would start half a step late on average (and the fit add that to latency)
        held = goals[np.clip(np.searchsorted(t, steps + self.dt / 2, side="right") - 1, 0, len(t) - 1)]
        data = mujoco.MjData(self.model)
        self.angles.place(data.qpos, present[0])
        state = sysid.create_initial_state(self.model, data.qpos.copy(), np.zeros(self.model.nv))
        control = sysid.TimeSeries(steps, held)
        measured = sysid.TimeSeries(t, present, {joint_sensor(j): (sysid.SignalType.MjSensor, np.array([k]))
                                                  for k, j in enumerate(self.joints)})
        return sysid.ModelSequences(seg.name.replace(" ", "_"), self.spec, seg.name, state, control, measured,
                                    allow_missing_sensors=True)  # only the joint angles are recorded

    def modify_residual(self, params, predicted, measured, model, return_pred_all, state=None, **_):
        """Simulated encoder angles (servo + play), delayed by the latency and sampled at the
        recorded rows' times, minus the recorded angles [deg]."""
        from mujoco import sysid

        qpos = state[:, 1:1 + model.nq]
        angles = self.angles.read(qpos)
        t_sim = state[:, 0]
        delay = params[LATENCY[0]].value[0] / 1e3
        t = measured.times
        pred = np.stack([np.interp(t - delay, t_sim, angles[:, k]) for k in range(angles.shape[1])], axis=1)
        # the lead only lets the replay settle (its gears start centred in their play, the
        # robot's rest against one side): it is not compared
        settled = t >= LEAD_S - 1e-9
        residual = np.degrees(pred[settled] - measured.data[settled])
        return (residual.ravel(), sysid.TimeSeries(t[settled], pred[settled], measured.signal_mapping),
                sysid.TimeSeries(t[settled], measured.data[settled], measured.signal_mapping))

    # -- fitting ---------------------------------------------------------------------------------
    def residual_fn(self, segments: Sequence[int] | None = None):
        """``mujoco.sysid``'s residual over every segment, or those of index ``segments``."""
        from mujoco import sysid

        sequences = self.sequences if segments is None else [self.sequences[i] for i in segments]
        return sysid.build_residual_fn(models_sequences=sequences, build_model=self.build,
                                       modify_residual=self.modify_residual, resample_true=False)

    def rmse_deg(self, params, residual_fn) -> dict[str, float]:
        """Per joint, the root-mean-square error of the simulated encoder angles [deg] over
        every segment."""
        residuals, _, _ = residual_fn(params.as_vector(), params)
        squares, count = np.zeros(len(self.joints)), 0
        for r in residuals:
            r = np.asarray(r).reshape(-1, len(self.joints))
            squares += (r ** 2).sum(axis=0)
            count += len(r)
        return {j: float(math.sqrt(v / count)) for j, v in zip(self.joints, squares)}


@dataclass
class Identification:
    """What ``biped sysid`` found: per parameter its value, 95 % interval and whether the
    traces identify it; RMSE per joint before (nominal model) and after; the reality file."""

    parameters: dict[str, dict[str, Any]]
    rmse_deg_before: dict[str, float]
    rmse_deg_after: dict[str, float]
    reality: dict[str, Any]
    seconds: float
    iterations: int
    segments: int

    def summary(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def identify(paths: Sequence[Path | str], robot: RobotSpec, per_joint: bool = False, max_iters: int = 30,
             report_dir: Path | None = None, log: Callable[[str], None] = print) -> Identification:
    """Fit the servo model to the traces at ``paths`` (see the module docstring).

    Per servo model first, over every segment.  ``per_joint`` then refines each group of
    joints that moves together (a pair, the waist) on its own segments only, from those
    values, the bus's latency held: a handful of parameters at a time instead of all of them
    at once (whose finite differences would replay every segment once per parameter)."""
    began = time.monotonic()
    traces = check_traces(paths, robot, warn=log)
    fit = Fit(robot, traces)
    residual_fn = fit.residual_fn()
    before = fit.rmse_deg(fit.nominal_params(), residual_fn)
    log(f"fitting {len(fit.params.as_vector())} parameters to {len(fit.segments)} segments of {len(traces)} "
        f"trace(s); RMSE on the nominal model {max(before.values()):.2f} deg (worst joint)")
    iterations = [0]
    params, result = _optimize(fit.params, residual_fn, max_iters, log, iterations)
    parameters = _intervals(params, result, residual_fn)
    report = (fit, params, result, residual_fn)
    if per_joint:
        fit, params, joint_parameters = _per_joint(robot, traces, fit, params, max_iters, log, iterations)
        parameters = {LATENCY[0]: parameters[LATENCY[0]], **joint_parameters}
        residual_fn = fit.residual_fn()
    after = fit.rmse_deg(params, residual_fn)
    if report_dir is not None:
        write_report(report_dir, *report, joint_fit=(fit, params, residual_fn) if per_joint else None)
    return Identification(parameters, before, after, reality_of(fit, parameters), time.monotonic() - began,
                          iterations[0], len(fit.segments))


def _optimize(params, residual_fn, max_iters: int, log: Callable[[str], None], iterations: list[int]):
    """``mujoco.sysid.optimize`` with this module's settings, logging each iteration."""
    from mujoco import sysid

    def progress(trace) -> None:
        iterations[0] += 1
        log(f"  iteration {iterations[0]}: cost {trace[-1].objective:.4g}")

    return sysid.optimize(params, residual_fn, optimizer="mujoco", verbose=False, max_iters=max_iters,
                          eps=FD_STEP, x_scale="jac", iter_callback=progress,
                          output=io.StringIO())  # its own table per iteration: `progress` instead


def _intervals(params, result, residual_fn) -> dict[str, dict[str, Any]]:
    """Each fitted (not frozen) parameter's value, 95 % interval within its bounds, and
    whether the interval is narrow enough to call it identified."""
    from mujoco import sysid

    residuals, _, _ = residual_fn(result.x, params)
    _, half_widths = sysid.calculate_intervals(residuals, result.jac)
    out = {}
    for (name, p), half in zip(((n, p) for n, p in params.items() if not p.frozen), half_widths, strict=True):
        low, high, value = float(p.min_value[0]), float(p.max_value[0]), float(p.value[0])
        finite = bool(np.isfinite(half))
        out[name] = {"value": value, "low": max(low, value - float(half)) if finite else low,
                     "high": min(high, value + float(half)) if finite else high,
                     "identifiable": finite and 2 * float(half) <= UNIDENTIFIABLE_SHARE * (high - low)}
    return out


def _per_joint(robot: RobotSpec, traces: Sequence[Trace], model_fit: "Fit", model_params, max_iters: int,
               log: Callable[[str], None], iterations: list[int]):
    """Refine per joint from the per-model fit: each group of joints that moves together on
    its own segments, everything else (latency included) held."""
    fit = Fit(robot, traces, per_joint=True)
    params = fit.params.copy()
    for group, members in model_fit.groups.items():
        for k in members:
            for key, *_ in SERVO_PARAMETERS:
                params[fit.name(fit.joints[k], key)].value[:] = model_params[model_fit.name(group, key)].value
    params[LATENCY[0]].value[:] = model_params[LATENCY[0]].value
    moved: dict[tuple[str, ...], list[int]] = {}
    for index, seg in enumerate(fit.segments):
        moved.setdefault(seg.joints or tuple(fit.joints), []).append(index)
    parameters: dict[str, dict[str, Any]] = {}
    for joints, indices in moved.items():
        log(f"per joint: {', '.join(joints)} on {len(indices)} segment(s)")
        mine = {fit.name(j, key) for j in joints for key, *_ in SERVO_PARAMETERS}
        sub = params.copy()
        for name, p in sub.items():
            p.frozen = name not in mine
        residual_fn = fit.residual_fn(indices)
        sub, result = _optimize(sub, residual_fn, max_iters, log, iterations)
        parameters.update(_intervals(sub, result, residual_fn))
        for name in mine:
            params[name].value[:] = sub[name].value
    for name, p in params.items():  # joints no segment moved keep their servo model's values
        if name != LATENCY[0] and name not in parameters:
            parameters[name] = {"value": float(p.value[0]), "low": float(p.min_value[0]),
                                "high": float(p.max_value[0]), "identifiable": False}
    return fit, params, parameters


def reality_of(fit: Fit, parameters: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The identified values as a reality file's contents (fixed values): robot-wide when one
    group covers every joint, else per joint under ``joints:``."""
    doc: dict[str, Any] = {"latency_ms": round(parameters[LATENCY[0]]["value"], 2)}
    per_group = {group: {key: round(parameters[fit.name(group, key)]["value"], 4) for key, *_ in SERVO_PARAMETERS}
                 for group in fit.groups}
    if len(fit.groups) == 1:
        doc.update(next(iter(per_group.values())))
    else:
        doc["joints"] = {fit.joints[k]: values for group, values in per_group.items() for k in fit.groups[group]}
    return doc


def write_report(folder: Path, fit: Fit, opt_params, result, residual_fn, joint_fit=None) -> None:
    """``mujoco.sysid``'s HTML report of the per-model fit (fit, parameter tables, confidence
    intervals) in ``folder``, and an overlay plot of recorded and simulated angles with the
    nominal and the final model (``joint_fit``: (fit, params, residual) of the per-joint one)."""
    from mujoco import sysid

    folder.mkdir(parents=True, exist_ok=True)
    # save_path=None: it would write report.html itself, in place; written whole here instead
    report = sysid.default_report(fit.sequences, fit.params, opt_params, residual_fn, result,
                                  title=f"System identification: {fit.robot.name}", save_path=None,
                                  build_model=fit.build, generate_videos=False)
    write_text_atomic(folder / "report.html", report.build())
    final_fit, final_params, final_fn = joint_fit or (fit, opt_params, residual_fn)
    plot_overlay(final_fit, fit.nominal_params(), final_params, final_fn, folder / "overlay.png", nominal_fn=residual_fn)


def plot_overlay(fit: Fit, before, after, residual_fn, path: Path, nominal_fn=None) -> None:
    """Recorded and simulated angles of each excited group's segments, with the nominal
    (``before``, through ``nominal_fn`` if its parameters differ in layout) and the identified
    model, one row a segment (its first moving joint)."""
    from sim2real.figures import pyplot, save_figure

    plt = pyplot()

    curves = {}
    for label, params, fn in (("nominal model", before, nominal_fn or residual_fn), ("identified", after, residual_fn)):
        _, preds, records = fn(params.as_vector(), params, return_pred_all=True)
        curves[label] = [p[0] for p in preds]
    records = [r[0] for r in records]
    rows = len(fit.segments)
    fig, axes = plt.subplots(rows, 1, figsize=(10, 1.9 * rows), squeeze=False)
    for ax, seg, record, nominal, fitted in zip(axes[:, 0], fit.segments, records, curves["nominal model"],
                                                curves["identified"]):
        k = int(np.argmax(np.ptp(record.data, axis=0)))
        ax.plot(record.times, np.degrees(record.data[:, k]), color="black", lw=1.2, label="recorded")
        ax.plot(record.times, np.degrees(nominal.data[:, k]), color="tab:red", lw=0.8, alpha=0.8, label="nominal model")
        ax.plot(record.times, np.degrees(fitted.data[:, k]), color="tab:blue", lw=0.8, ls="--", label="identified")
        ax.set_ylabel("deg")
        ax.set_title(f"{seg.name}: {fit.joints[k]}", fontsize=9, loc="left")
    axes[0, 0].legend(loc="upper right", fontsize=8, ncol=3)
    axes[-1, 0].set_xlabel("time in segment [s]")
    fig.tight_layout()
    save_figure(fig, path, dpi=90)
