"""The names the command line lists in its help texts, kept free of numpy so that `--help` starts fast.

Their owners import them from here (one source of truth): samples, verify.scenes, sim.integrate,
solver_settings, schemas, io.limits and guidelines.
"""

SAMPLES = ("beam", "plate", "conrod", "genstruct1", "genstruct2", "carbody")  # samples.RECIPES, in this order
SCENES = ("free-spin", "mode-release", "spin-up", "torque-pulse", "minor-axis")
FIXED = ("rk4", "rk4-lie", "midpoint")  # the integrators with a fixed step
ADAPTIVE = ("dop853", "exponential", "scipy-dop853", "rk45", "radau", "bdf", "lsoda")  # exponential: sim.lawson
INTEGRATORS = FIXED + ADAPTIVE
SOLVERS = ("adams", "recurdyn", "exudyn", "chrono")  # solver_settings.SETTINGS
SCHEMA_COMMANDS = ("info", "analyze", "gate", "compare", "settings", "simulate", "verify", "modes", "diff")  # with --json
MAX_MEMORY_ENV = "FFRF_ADVISOR_MAX_MEMORY"
LEVELS = ("I", "II", "III", "IV")  # the equation-of-motion levels (guidelines; gate checks --max-level first)
