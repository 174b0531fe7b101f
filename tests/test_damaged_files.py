"""Issue 49, parts 3 and 4 through the CLI: checksums of .ffrf.h5 (Fletcher-32 per chunk, SHA-256 of the caches
and of the nodal data they came from) and numbers that are not numbers, in every reader of this helper's."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from ffrf_advisor.cli import app
from ffrf_advisor.io import ffrf_h5, read_body, write_body

BEAM = Path(__file__).resolve().parent.parent / "sample_bodies" / "beam.ffrf.h5"
runner = CliRunner()


def refused(args: list[str], *words: str) -> str:
    """The command ends with exit 2 and one line naming ``words``."""
    result = runner.invoke(app, [str(a) for a in args])
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and all(w in lines[0] for w in words), result.output
    return lines[0]


@pytest.fixture(scope="module")
def beam():
    return read_body(BEAM, load_fe=True)


def written(tmp_path, body, name="beam.ffrf.h5", cache=True) -> Path:
    path = tmp_path / name
    write_body(body, path, cache_invariants=cache)
    return path


def flip_in_chunk(path: Path, dataset: str) -> None:
    """One bit flipped in the middle of the first stored chunk of ``dataset`` (as a disk or a copy would)."""
    with h5py.File(path, "r") as f:
        info = f[dataset].id.get_chunk_info(0)
    with open(path, "r+b") as fh:
        fh.seek(info.byte_offset + info.size // 2)
        byte = fh.read(1)[0]
        fh.seek(info.byte_offset + info.size // 2)
        fh.write(bytes([byte ^ 0x10]))


def commands(path: Path, out: Path) -> list[list]:
    return [["info", path], ["analyze", path, "--speed", "30"], ["convert", path, out]]


def test_every_dataset_is_written_with_its_fletcher32_checksum(tmp_path, beam):
    path = written(tmp_path, beam)
    with h5py.File(path) as f:
        names = []
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        assert "modes/Phi" in names and "invariants/Sbar" in names
        assert all(f[n].fletcher32 and f[n].chunks for n in names)
        assert f.attrs["version"] == ffrf_h5.VERSION == 4


def test_a_bit_flipped_in_the_modes_is_refused_by_every_command_that_reads_them(tmp_path, beam):
    """Without the invariants cache info and analyze stream modes/Phi; convert reads it whole."""
    path = written(tmp_path, beam, cache=False)
    flip_in_chunk(path, "modes/Phi")
    for args in commands(path, tmp_path / "out.ffrf.h5"):
        refused(args, str(path), "modes/Phi", "Fletcher-32")
    assert not (tmp_path / "out.ffrf.h5").exists()


@pytest.mark.parametrize("dataset", ["invariants/Ibar", "nodal_summary/max_deflection", "modes/eigenvalues"])
def test_a_bit_flipped_in_the_cache_is_refused_by_info_analyze_and_convert(tmp_path, beam, dataset):
    path = written(tmp_path, beam)
    flip_in_chunk(path, dataset)
    for args in commands(path, tmp_path / "out.ffrf.h5"):
        refused(args, str(path), dataset, "Fletcher-32")


def test_a_changed_attribute_fails_the_cache_checksum(tmp_path, beam):
    """invariants@mass x2 (an attribute: Fletcher-32 covers datasets only) changes the advice's inputs."""
    path = written(tmp_path, beam)
    with h5py.File(path, "r+") as f:
        f["invariants"].attrs["mass"] *= 2
    info, analyze, convert = commands(path, tmp_path / "out.ffrf.h5")
    refused(info, str(path), "checksums@invariants_sha256")
    refused(analyze, str(path), "checksums@invariants_sha256")
    refused(convert, str(path), "invariants@mass", "nodal sums")  # it reads the nodal data: they say more


@pytest.mark.parametrize("dataset, factor", [("modes/eigenvalues", 0.25), ("stress/max", 100.0)])
def test_per_mode_data_rewritten_through_hdf5_fail_their_sha256_on_the_cached_path(tmp_path, beam, dataset, factor):
    """Eigenvalues x0.25 or stress/max x100 rewritten through h5py (Fletcher-32 recomputed, so it holds): the cached
    path of info and analyze has no second copy of them, the per-mode digest catches them (issue 49)."""
    path = written(tmp_path, beam)
    with h5py.File(path, "r+") as f:
        f[dataset][...] = f[dataset][...] * factor
    info, analyze, _ = commands(path, tmp_path / "out.ffrf.h5")
    refused(info, str(path), "checksums@per_mode_sha256")
    refused(analyze, str(path), "checksums@per_mode_sha256")


def test_nodal_data_changed_below_the_cache_tolerance_fail_their_sha256(tmp_path, beam):
    """One value of modes/Phi changed in its last bit through HDF5 (its chunk checksum rewritten): the caches agree
    with it to 1e-6 (ffrf_h5.CACHE_TOLERANCE), the SHA-256 of the nodal data does not; the cached path does not
    read the nodal data, so info still reads the file."""
    path = written(tmp_path, beam)
    with h5py.File(path, "r+") as f:
        value = f["modes/Phi"][5, 1, 0]
        f["modes/Phi"][5, 1, 0] = np.nextafter(value, np.inf)
    refused(["convert", path, tmp_path / "out.ffrf.h5"], "checksums@nodal_sha256", "nodal data")
    assert runner.invoke(app, ["info", str(path)]).exit_code == 0


def test_a_changed_header_attribute_fails_its_checksum(tmp_path, beam):
    """t-mm-N-s -> t-m-N-s: every number then means another thing (attributes carry no Fletcher-32)."""
    path = written(tmp_path, beam)
    with h5py.File(path, "r+") as f:
        f.attrs["units"] = "t-m-kN-s"
    refused(["analyze", path, "--speed", "30"], "checksums@attributes_sha256", "header attributes")


def test_a_cache_left_out_is_computed_from_the_nodal_data_they_guard(tmp_path, beam):
    """Deleting a cache is no silent change: the reader streams the nodal data, which nodal_sha256 guards."""
    path = written(tmp_path, beam)
    with h5py.File(path, "r+") as f:
        del f["invariants"]
        f["modes/Phi"][0, 0, 0] = np.nextafter(f["modes/Phi"][0, 0, 0], np.inf)
    refused(["info", path], "checksums@nodal_sha256")


def test_a_format_4_file_without_its_checksums_is_refused(tmp_path, beam):
    path = written(tmp_path, beam)
    with h5py.File(path, "r+") as f:
        del f["checksums"]
    refused(["info", path], "checksums", "missing")


def test_a_dataset_rewritten_without_its_checksum_is_refused(tmp_path, beam):
    path = written(tmp_path, beam)
    with h5py.File(path, "r+") as f:
        data = f["modes/eigenvalues"][()]
        del f["modes/eigenvalues"]
        f.create_dataset("modes/eigenvalues", data=data)
    refused(["info", path], "modes/eigenvalues", "Fletcher-32")


def test_a_file_of_format_3_is_read_with_a_note(tmp_path, beam):
    """Files written before checksums still read; the provenance says they carry none, and convert adds them."""
    path = written(tmp_path, beam)
    with h5py.File(path, "r+") as f:
        del f["checksums"]
        f.attrs["version"] = 3
    old = read_body(path, load_fe=True)
    assert ffrf_h5.UNCHECKED in old.provenance.notes
    result = runner.invoke(app, ["info", str(path)], env={"COLUMNS": "200"})
    assert result.exit_code == 0 and "no checksums" in result.output
    out = tmp_path / "new.ffrf.h5"
    assert runner.invoke(app, ["convert", str(path), str(out)]).exit_code == 0
    new = read_body(out, load_fe=True)
    assert ffrf_h5.UNCHECKED not in new.provenance.notes and np.array_equal(new.fe.Phi, old.fe.Phi)


@pytest.mark.parametrize("attribute, value", [("invariants@mass", True), ("invariants@mass", "1.0"),
                                              ("material@E", np.bool_(True)), ("nodal_summary@n_nodes", 3.0),
                                              ("@version", True)])
def test_hdf5_attributes_that_are_not_numbers_are_refused(tmp_path, beam, attribute, value):
    """A bool, a string or a float where a whole number belongs is refused by its own check, before any
    checksum (the cache's would refuse it too, naming less)."""
    path = written(tmp_path, replace(beam, fe=replace(beam.fe, material=_steel())))
    group, key = attribute.split("@")
    with h5py.File(path, "r+") as f:
        (f[group] if group else f).attrs[key] = value
    refused(["info", path], attribute)


def _steel():
    from ffrf_advisor.fe.material import Material
    return Material("steel", 210000.0, 0.3, 7.85e-9)


@pytest.mark.parametrize("key", ["mass", "I1"])
@pytest.mark.parametrize("value", [True, "1.0", [1.0], {"v": 1.0}])
def test_ffinv_json_numbers_that_are_not_numbers_are_refused(tmp_path, beam, key, value):
    """"I1": true was read as a mass of 1."""
    path = tmp_path / "beam.ffinv.json"
    write_body(beam, path)
    doc = json.loads(path.read_text())
    target = doc if key in doc else next(v for v in doc.values() if isinstance(v, dict) and key in v)
    target[key] = value
    path.write_text(json.dumps(doc))
    refused(["info", path], str(path), key)
