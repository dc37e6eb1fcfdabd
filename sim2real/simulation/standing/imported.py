"""Does the robot ``biped robot import`` just inferred stand?  And if not, a home that does.

The importer (:mod:`sim2real.simulation.model.importing.importer`) guesses the joint map from the model's structure
and takes the home from a keyframe ``home`` or the zero pose: straight legs, from which no
walker starts.  Here, before the YAML is written, the guessed robot is loaded from the very
text the YAML will hold and given the stand check (:func:`~sim2real.simulation.standing.check.check_stand`,
5 s from home with the servos holding it).  Where :func:`~sim2real.simulation.standing.home.needs_home`
says the home falls or has straight knees, :func:`~sim2real.simulation.standing.home.propose_home`
proposes one (knees bent, feet flat, the centre of mass over the soles) with each leg joint's
range centred on it within the model's limits; the import's joints take that home and those
ranges (marked guessed), and the robot is checked again as the YAML will be written.

    result = import_robot("kit.urdf", "kit.yaml", servo="XM430-W350")
    result = stand_imported(result)         # result.stand: before, proposal, after
    write_robot_yaml(result)

This glue is called by the command line: the importer (model building) never imports the
standing checks, which judge what it builds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from sim2real.errors import BipedError
from sim2real.robot import RobotSpec, parse_robot
from sim2real.simulation.model.importing.robot_yaml import robot_yaml
from sim2real.simulation.model.importing.importer import GUESSED, ImportResult, JointGuess, number_text
from sim2real.simulation.model.physique import measured
from sim2real.robot.validation import parse_yaml
from sim2real.simulation.standing.check import STAND_S, StandReport, check_stand
from sim2real.simulation.standing.home import HomeProposal, NoStandingHome, needs_home, propose_home


@dataclass(frozen=True)
class ImportStand:
    """The stand check of an imported robot: at its imported home, and with the home proposed."""

    before: StandReport | None  # at the imported home; None when the robot does not load yet
    why: str | None = None  # why a home was proposed (needs_home), None when the home was kept
    proposal: HomeProposal | None = None
    after: StandReport | None = None  # the robot as the YAML holds it, with the proposed home
    problem: str = ""  # why the check did not run, or why no home was proposed

    @property
    def verdict(self) -> str | None:
        """The verdict of the robot as written: after the proposal if there is one."""
        final = self.after or self.before
        return final.verdict if final is not None else None

    def report(self) -> list[str]:
        """What the import report says, one fact a line."""
        if self.before is None:
            return [f"stand check: not run ({self.problem}): fix the YAML, then `biped robot stand` it"]
        out = [f"stand check ({STAND_S:g} s from home, the servos holding it), at the imported home: "
               + _summary(self.before)]
        if self.why is None:
            out.append("  home kept: it stands from bent knees")
        elif self.proposal is None:
            out.append(f"  {self.why}; NO HOME PROPOSED: {self.problem} (set home_deg by hand, see "
                       "docs/robot-stand.md)")
        else:
            out.append(f"  {self.why}: a home is proposed and written")
            out += [f"  {line}" for line in self.proposal.report()]
        if self.after is not None:
            out.append("stand check with the proposed home, as the YAML holds it: " + _summary(self.after))
        return out

    def yaml_comments(self) -> list[str]:
        """The YAML header's lines on it (without ``#``)."""
        if self.before is None:
            return [f"STAND CHECK NOT RUN: {self.problem}"]
        out = [f"Stand check at the model's home ({STAND_S:g} s, servos holding): {self.before.verdict}"]
        if self.proposal is not None and self.after is not None:
            p = self.proposal
            out += [f"{self.why}: home_deg and range_deg of the leg joints are PROPOSED ({GUESSED}):",
                    f"  knees bent {p.knee_deg:g} deg, hip and ankle pitch solved so that the feet are flat and the "
                    "centre of mass is over the soles;",
                    "  each leg range centred on that stance within the model's limits, because the networks "
                    "drive the",
                    "  central 80 % of each range and rest at its middle;",
                    f"  with it the robot {self.after.verdict} ({self.after.reason}). Check it: "
                    "`biped robot stand` this file."]
        elif self.why is not None:
            out.append(f"{self.why}; NO HOME PROPOSED: {self.problem}")
        return out


def _summary(report: StandReport) -> str:
    return (f"{report.verdict}: up-vector z {report.up_z_final:.4f}, sag {1e3 * report.sag_m:.1f} mm, the feet "
            f"carry {100 * report.feet_weight_share:.0f} % of its weight ({report.reason})")


def imported_robot(result: ImportResult) -> RobotSpec:
    """The robot ``result`` describes, read from the YAML text it would write (paths relative
    to ``result.output``), measured; :class:`~sim2real.errors.ConfigError` when it does not load."""
    source = str(result.output)
    return measured(parse_robot(parse_yaml(robot_yaml(result), source), source))


def stand_imported(result: ImportResult) -> ImportResult:
    """``result`` with its stand check (``result.stand``) and, where the home falls or has
    straight knees, the proposed home and centred leg ranges in its joints (module docstring)."""
    try:
        robot = imported_robot(result)
        before = check_stand(robot)
    except BipedError as exc:  # a map the user must complete first (a foot not found...)
        return replace(result, stand=ImportStand(None, problem=str(exc)))
    why = needs_home(robot, before)
    if why is None:
        return replace(result, stand=ImportStand(before))
    # the import's ranges are the model's limits, made anatomical and cut to each servo's reach
    limits = {j.name: (math.radians(j.range_deg[0]), math.radians(j.range_deg[1])) for j in result.joints}
    try:
        proposal = propose_home(robot, limits=limits)
    except (NoStandingHome, ValueError) as exc:  # no bend stands, or a leg without a pitch joint
        return replace(result, stand=ImportStand(before, why, problem=str(exc)))
    joints = [_stance(j, proposal) for j in result.joints]
    proposed = replace(result, joints=joints)
    after = check_stand(imported_robot(proposed))
    return replace(proposed, stand=ImportStand(before, why, proposal, after))


def _stance(j: JointGuess, proposal: HomeProposal) -> JointGuess:
    """A joint with the proposal's home and (for a leg joint) its centred range [deg], noted."""
    if j.name not in proposal.centred:
        return j
    home = round(math.degrees(proposal.home_rad[j.name]), 1) + 0.0  # + 0.0: no -0
    lo, hi = (round(math.degrees(a), 1) + 0.0 for a in proposal.range_rad[j.name])
    note = (f"home and range {GUESSED}: the proposed stance, the model's [{number_text(j.range_deg[0])}, "
            f"{number_text(j.range_deg[1])}] centred on it")
    return replace(j, home_deg=home, range_deg=(lo, hi), notes=(*j.notes, note))
