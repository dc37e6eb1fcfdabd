"""Largest sizes an evolution or an evaluation may ask for: config keys and flags alike.

Each of these allocates in proportion (a simulation's state and noise draws in MuJoCo's batch,
an MjData of ~16 MB per thread, genomes, folders) or takes time in proportion, so a typo
(``--population 100000000``) would end in ``std::bad_alloc`` or a machine brought to its
knees.  Each bound is far beyond any run the project has made (the shipped configs' values in
brackets), and refused with the key or flag named.  No imports: the command line reads it
before MuJoCo loads.
"""

from __future__ import annotations

MAX_POPULATION = 10_000  # neat.population_size, --population [512]
MAX_GENERATIONS = 1_000_000  # generations, stages[].generations, --generations [400]
MAX_THREADS = 256  # threads, --threads (0: every core) [0]
MAX_EPISODES = 64  # randomize.episodes: episodes per genome [6]
MAX_VALIDATION_DRAWS = 1_000  # randomize.validation.draws [10]
MAX_CANDIDATES = 64  # randomize.validation.candidates [8]
MAX_STAGES = 16  # stages of a hierarchy [3]
MAX_EPISODE_S = 300.0  # task.episode_s, eval/plot gait/render --seconds [s] [20]
MAX_EVAL_EPISODES = 1_000  # eval --episodes [100 for --by-perturbation]
# Control ticks a generation simulates: simulations (population x episodes, or validation's
# candidates x draws) x ticks an episode.  A randomized tick holds ~130 bytes of noise draws,
# so this is ~1.3 GB at most; it is also ~3 minutes a generation on one core.  [0.6 million]
MAX_GENERATION_TICKS = 10_000_000
