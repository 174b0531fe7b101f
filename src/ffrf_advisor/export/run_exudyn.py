"""Run a body written by ``ffrf-advisor export BODY --solver exudyn -o DIR`` in EXUDYN and write its trajectory.

    python run_exudyn.py [--omega0 WX,WY,WZ] [--q0 Q1,...] [--qd0 V1,...] [--t-end T] [--step H]
                         [--output-step DT] [-o trajectory.csv]

The body (body.npz beside this script): node positions, the mass matrix, the mass-normalised modes and
their eigenvalues, in the body's units (the file's ``units``). The scene (scene.json beside it) gives the
defaults: a free body started with the angular velocity omega0 (body frame) and modal coordinates q0, qd0,
integrated with EXUDYN's explicit RK44 on the rotation group at a fixed step. Times are in the body's time
unit.

EXUDYN's ObjectFFRFreducedOrder evaluates every inertia term of the floating frame of reference (it has no
switches) and no geometric stiffening: it runs ffrf-advisor's full set (terms I-IV), not an advised subset.
The modal stiffness is the file's eigenvalues (the modes are mass-normalised), so no stiffness matrix is
needed. Needs ``pip install exudyn`` (tested with 1.13); not part of ffrf-advisor.

The trajectory (CSV): time, the angular velocity in the body frame, the rotation matrix body to global
(row-major) and the modal coordinates, one row per output step.
"""
import argparse
import csv
import json
import os

import numpy as np
import scipy.sparse as sp

HERE = os.path.dirname(os.path.abspath(__file__))


def load_body(directory):
    """Nodes (n x 3), mass matrix (3n x 3n CSR, node-interleaved), modes (3n x m), eigenvalues, unit names."""
    with np.load(os.path.join(directory, "body.npz"), allow_pickle=False) as f:
        M = sp.csr_matrix((f["mass_data"], f["mass_indices"], f["mass_indptr"]), shape=tuple(f["mass_shape"]))
        return {"nodes": f["nodes"], "M": M, "modes": f["modes"], "eigenvalues": f["eigenvalues"],
                "name": str(f["name"]), "units": {k: str(f[k + "_unit"]) for k in ("mass", "length", "time")}}


def build(mbs, body, omega0, q0, qd0):
    """The free body in ``mbs``: EXUDYN's FEMinterface filled by hand, the reduced-order object added."""
    from exudyn.FEM import FEMinterface, ObjectFFRFreducedOrderInterface
    n = len(body["nodes"])
    fem = FEMinterface()
    fem.nodes = {"Position": body["nodes"]}
    fem.massMatrix = body["M"]
    fem.stiffnessMatrix = sp.csr_matrix((3 * n, 3 * n))  # unused: the modal stiffness is set below
    fem.modeBasis = {"matrix": body["modes"]}
    fem.eigenValues = body["eigenvalues"]
    cms = ObjectFFRFreducedOrderInterface(fem, rigidBodyNodeType="NodeType.RotationRotationVector")
    cms.stiffnessMatrixReduced = np.diag(body["eigenvalues"])
    added = cms.AddObjectFFRFreducedOrder(mbs, positionRef=[0, 0, 0], initialVelocity=[0, 0, 0],
                                          initialAngularVelocity=list(omega0), gravity=[0, 0, 0])
    mbs.SetNodeParameter(added["nGenericODE2"], "initialCoordinates", list(q0))
    mbs.SetNodeParameter(added["nGenericODE2"], "initialCoordinates_t", list(qd0))
    return added


def run(body, scene):
    """(t, w, R, q) of the scene sampled every output step."""
    import exudyn as exu
    from exudyn.utilities import SensorNode
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    added = build(mbs, body, scene["omega0"], scene["q0"], scene["qd0"])
    kinds = {"w": (added["nRigidBody"], exu.OutputVariableType.AngularVelocityLocal),
             "R": (added["nRigidBody"], exu.OutputVariableType.RotationMatrix),
             "q": (added["nGenericODE2"], exu.OutputVariableType.Coordinates)}
    sensors = {k: mbs.AddSensor(SensorNode(nodeNumber=node, outputVariableType=kind, storeInternal=True))
               for k, (node, kind) in kinds.items()}
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ss.timeIntegration.numberOfSteps = int(round(scene["t_end"] / scene["step"]))
    ss.timeIntegration.endTime = scene["t_end"]
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.explicit.computeMassMatrixInversePerBody = False
    ss.timeIntegration.explicit.useLieGroupIntegration = True
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = scene["output_step"]
    ss.show.statistics = False
    ss.show.computationTime = False
    exu.SolveDynamic(mbs, ss, solverType=exu.DynamicSolverType.RK44)
    data = {k: mbs.GetSensorStoredData(s) for k, s in sensors.items()}
    return data["w"][:, 0], data["w"][:, 1:4], data["R"][:, 1:10], data["q"][:, 1:]


def write_csv(path, units, t, w, R, q):
    """One row per sample; each header names its unit in the body's units."""
    mass, length, time = units["mass"], units["length"], units["time"]
    names = ([f"t [{time}]"] + [f"w{c} [rad/{time}]" for c in "xyz"]
             + [f"R{i}{j} [-]" for i in "123" for j in "123"]
             + [f"q{k + 1} [sqrt({mass}) {length}]" for k in range(q.shape[1])])
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(names)
        writer.writerows([[repr(float(x)) for x in row] for row in np.column_stack([t, w, R, q])])


def numbers(text, n):
    values = [float(x) for x in text.split(",")]
    if len(values) != n:
        raise SystemExit(f"expected {n} comma-separated numbers, got {text!r}")
    return values


def main(argv=None):
    with open(os.path.join(HERE, "scene.json")) as fh:
        scene = json.load(fh)
    body = load_body(HERE)
    nf = len(body["eigenvalues"])
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--omega0", help="angular velocity WX,WY,WZ, body frame [rad/time unit]")
    p.add_argument("--q0", help="initial modal coordinates Q1,...")
    p.add_argument("--qd0", help="initial modal velocities V1,...")
    p.add_argument("--t-end", type=float, help="end time [time unit]")
    p.add_argument("--step", type=float, help="fixed step of RK44 [time unit]")
    p.add_argument("--output-step", type=float, help="sampling interval [time unit]")
    p.add_argument("-o", "--output", default="trajectory.csv", help="trajectory file (CSV)")
    args = p.parse_args(argv)
    for key, n in (("omega0", 3), ("q0", nf), ("qd0", nf)):
        if getattr(args, key) is not None:
            scene[key] = numbers(getattr(args, key), n)
    for key in ("t_end", "step", "output_step"):
        if getattr(args, key) is not None:
            scene[key] = getattr(args, key)
    write_csv(args.output, body["units"], *run(body, scene))
    print(f"wrote {args.output}: {body['name']} in EXUDYN, {nf} modes, RK44 step {scene['step']:g} "
          f"to {scene['t_end']:g} (every inertia term, no geometric stiffening)")


if __name__ == "__main__":
    main()
