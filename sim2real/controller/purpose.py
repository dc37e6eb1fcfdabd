"""What a controller was evolved to do - walk, reach, stand or hold a pose - read from the file.

Commands that only make sense for one task (``biped polish`` and ``biped adapt`` tune a
walker's walk rate; ``biped eval --ablate`` and ``--by-perturbation`` count walks) refuse a
controller of another task, saying which task it has and how that was told:

1. a controller that reads a reach target (the ``reach`` input channel, seed 002's state
   machine) reaches - the runtime runs it as a reacher whatever else the file says;
2. else its top module (the last of ``modules``) names the stage it was evolved in, and the
   run's config in its provenance gives that stage's objective (``pose``, ``stand``, ``walk``,
   ``reach``);
3. else it walks: a run without stages evolves walkers (the evaluator's default objective).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from sim2real.controller.file import Controller
from sim2real.errors import ConfigError
from sim2real.robot.validation import show

WALK = "walk"
# every task a stage may evolve for (evolve.locomotion.objectives.OBJECTIVES), as a sentence says it
DESCRIBED = {"walk": "a walker", "reach": "a reaching controller", "stand": "a standing controller",
             "pose": "a posing controller (it holds the home pose)"}


@dataclass(frozen=True)
class Purpose:
    task: str  # a key of DESCRIBED
    why: str  # how it was told, for a message

    def describe(self) -> str:
        return f"{DESCRIBED[self.task]} ({self.why})"


def purpose_of(data: Controller) -> Purpose:
    """The task ``data`` was evolved for (the module docstring's rules, in order)."""
    if "reach" in data.input_channels:
        return Purpose("reach", "it reads a reach target: reach_input")
    top = data.modules[-1] if data.modules else None
    for stage in _stages(data.provenance):
        objective = stage.get("objective")
        if stage.get("name") == top and objective in DESCRIBED:
            return Purpose(objective, f"its top module {show(top)} was evolved for the {objective} objective, "
                           "as provenance.config.stages records")
    return Purpose(WALK, "evolved without stages, for the walk objective")


def require_walker(data: Controller, source: str, command: str, needs: str) -> None:
    """:class:`ConfigError` naming ``source`` unless ``data`` is a walker: ``command`` (e.g.
    ``biped polish``) ``needs`` one (what it does with it)."""
    purpose = purpose_of(data)
    if purpose.task != WALK:
        raise ConfigError(source, "task", f"{purpose.describe()}, not a walker: {command} needs a walker ({needs})")


def _stages(provenance: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """The stages of the run a controller came from, as its provenance records them (free-form:
    anything else is no stage)."""
    config = provenance.get("config")
    stages = config.get("stages") if isinstance(config, Mapping) else None
    if not isinstance(stages, (list, tuple)):
        return []
    return [s for s in stages if isinstance(s, Mapping)]
