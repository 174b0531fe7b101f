"""Modal stresses of a Nastran SOL 103 run: von Mises per mode at each grid from pyNastran's stress tables."""
from __future__ import annotations

import numpy as np


def nodal_stress(m, nm: int, grids: np.ndarray) -> np.ndarray | None:
    """Per mode, the von Mises stress at each grid (n, nm), averaged over the elements that share the grid.

    An element gives its corner values where Nastran wrote them (``STRESS(CORNER)``: solids, shells; beam
    ends; bar ends), else its one value to each of its grids. Per element and grid the largest over fibres is
    taken; bars and beams give their largest |fibre stress|, rods sqrt(axial^2 + 3 torsion^2). Values, not
    tensors, are averaged: Nastran gives shell tensors in each element's own frame.
    """
    index = {int(g): i for i, g in enumerate(grids)}
    samples = [s for name in m.op2_results.stress.get_table_types()
               for obj in getattr(m.op2_results.stress, name.split(".")[-1]).values() if obj.data.shape[0] == nm
               for s in _samples(m, obj, index)]
    if not samples:
        return None
    pairs = np.column_stack([np.concatenate([s[0] for s in samples]), np.concatenate([s[1] for s in samples])])
    values = np.concatenate([s[2] for s in samples], axis=1)
    keys, which = np.unique(pairs, axis=0, return_inverse=True)
    per_pair = np.zeros((len(keys), nm))
    np.maximum.at(per_pair, which.ravel(), values.T)  # the largest over fibres, layers and duplicate rows
    total, count = np.zeros((len(grids), nm)), np.zeros(len(grids))
    np.add.at(total, keys[:, 1], per_pair)
    np.add.at(count, keys[:, 1], 1)
    return total / np.maximum(count, 1)[:, None]


def _samples(m, obj, index: dict) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(element ids, grid indices, values (nm, k)) of one stress table, corner rows where present."""
    headers = obj.get_headers()
    data = np.asarray(obj.data, dtype=float)

    def largest(*names):
        cols = [headers.index(h) for h in names if h in headers]
        return np.abs(data[:, :, cols]).max(axis=2) if cols else None

    if not getattr(obj, "is_von_mises", True):
        return []
    if hasattr(obj, "element_node"):
        value = largest("von_mises", "ovm")
        value = largest("smax", "smin") if value is None else value
        if value is None:
            return []
        eids, nids = obj.element_node[:, 0], obj.element_node[:, 1]
        corner = nids > 0
        centre = ~corner & ~np.isin(eids, eids[corner])
        return [_at_grids(eids[corner], nids[corner], value[:, corner], index),
                _spread(m, eids[centre], value[:, centre], index)]
    if not hasattr(obj, "element"):
        return []
    if "smaxa" in headers:  # bars: end A at the first grid, end B at the second
        ends = [[m.elements[int(e)].node_ids[k] for e in obj.element] for k in (0, 1)]
        return [_at_grids(obj.element, np.array(ends[k]), largest(*cols), index)
                for k, cols in ((0, ("smaxa", "smina")), (1, ("smaxb", "sminb")))]
    if "axial" in headers and "torsion" in headers:
        axial, torsion = (data[:, :, headers.index(h)] for h in ("axial", "torsion"))
        return [_spread(m, obj.element, np.sqrt(axial**2 + 3 * torsion**2), index)]
    return []


def _at_grids(eids, nids, value: np.ndarray, index: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows at grids of the run (scalar points and others dropped)."""
    known = np.array([int(g) in index for g in nids], dtype=bool)
    grid = np.array([index[int(g)] for g in np.asarray(nids)[known]], dtype=np.int64)
    return np.asarray(eids)[known], grid, value[:, known]


def _spread(m, eids, value: np.ndarray, index: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An element's one value given to each of its grids."""
    rows = [(k, g) for k, e in enumerate(eids) for g in m.elements[int(e)].node_ids if g]
    take = np.array([k for k, _ in rows], dtype=np.int64)
    return _at_grids(np.asarray(eids)[take], np.array([g for _, g in rows]), value[:, take], index)
