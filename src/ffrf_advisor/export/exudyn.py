"""The body for EXUDYN's ObjectFFRFreducedOrder (docs/export.md): what its FEMinterface takes (node positions,
the node-interleaved mass matrix, the mass-normalised modes and their eigenvalues, theory section 1) in
``body.npz``, the scene in ``scene.json`` and the script ``run_exudyn.py`` that runs it."""
from __future__ import annotations

import json
import math
import shutil
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..body import FlexibleBody
from ..errors import FFRFError
from ..fe.assembly import full_mass
from ..io.atomic import atomic_directory
from ..sim.equations import split

DATA, SCENE, SCRIPT = "body.npz", "scene.json", "run_exudyn.py"
FILES = (DATA, SCENE, SCRIPT)
SAMPLES = 500  # default number of output samples
STEP_PHASE = 0.1  # default step: h Omega_max = 0.1, RK4's phase error per step (h Omega)^5 / 120 ~ 1e-7
NOTE = ("EXUDYN evaluates every inertia term of the floating frame (it has no term switches) and no geometric "
        "stiffening: the body runs with the full set (terms I-IV), whatever the advice")


@dataclass(frozen=True)
class Scene:
    """A free body's start and the run's times, in the body's units (time unit, rad per time unit)."""

    omega0: tuple[float, float, float]
    q0: tuple[float, ...]
    qd0: tuple[float, ...]
    t_end: float
    step: float
    output_step: float


def scene_of(y0: np.ndarray, nf: int, t_end: float, step: float, output_step: float | None) -> Scene:
    """The scene of the initial state ``y0`` (sim.model.initial_state's layout): the step shortened so that it
    divides ``t_end`` (EXUDYN takes a number of steps), the output step a whole number of steps (its sensors
    write at steps; default SAMPLES samples)."""
    n = math.ceil(t_end / step * (1 - 1e-12))
    h = t_end / n
    every = max(1, round((output_step or t_end / SAMPLES) / h))
    _, w0, q0, qd0 = split(y0, nf)
    return Scene(tuple(w0), tuple(q0), tuple(qd0), t_end, h, every * h)


def default_step(body: FlexibleBody) -> float:
    """The fixed RK44 step with h Omega_max = STEP_PHASE (in the body's time unit)."""
    return STEP_PHASE / float(np.sqrt(np.max(body.eigenvalues)))


def arrays(body: FlexibleBody, source: str) -> dict[str, np.ndarray]:
    """What ObjectFFRFreducedOrder needs: nodes, mass matrix (3n x 3n CSR), modes (3n x nf), eigenvalues."""
    fe = body.fe
    if fe is None:
        raise FFRFError(f"{source}: modes/Phi: expected nodal FE data (EXUDYN builds its invariants from the "
                        "nodes and the mass matrix), got invariants only")
    if fe.rotary is not None:
        raise FFRFError(f"{source}: modes/rotations: expected translational nodes only (EXUDYN's "
                        "ObjectFFRFreducedOrder has no nodal rotary inertia, theory 3b), got nodes with rotations")
    M = full_mass(fe.Ms).tocsr()
    return {"nodes": np.asarray(fe.mesh.points, float), "mass_data": M.data, "mass_indices": M.indices,
            "mass_indptr": M.indptr, "mass_shape": np.array(M.shape), "modes": fe.Phi.reshape(-1, body.nf),
            "eigenvalues": np.asarray(body.eigenvalues, float), "name": np.array(body.name),
            **{f"{k}_unit": np.array(getattr(body.units, k)) for k in ("mass", "length", "time")}}


def write(body: FlexibleBody, scene: Scene, directory: Path, source: str, force: bool = False) -> list[Path]:
    """``body.npz``, ``scene.json`` and ``run_exudyn.py`` written into a temporary folder that then takes
    ``directory``'s place whole (io.atomic.atomic_directory: the old files or the new ones, never a mix);
    refuses to replace them without ``force``, and a folder holding anything else."""
    data = arrays(body, source)
    with atomic_directory(directory, FILES, force) as tmp:
        with open(tmp / DATA, "wb") as fh:
            np.savez(fh, **data)
        (tmp / SCENE).write_text(json.dumps({"units": str(body.units), **asdict(scene)}, indent=1) + "\n")
        shutil.copyfile(Path(__file__).with_name(SCRIPT), tmp / SCRIPT)
    return [directory / name for name in FILES]
