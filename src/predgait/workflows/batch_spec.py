"""The dataset file of ``predgait batch``: subjects, trials, analyses, checked before any work.

Layout (TOML; paths relative to the file, ``bundled:NAME`` a file shipped with predgait)::

    name = "gait lab 2026"            # the dataset's name (default: the file's stem)
    analyses = ["leg", "fullbody"]    # per trial: planar leg inverse and/or 35-DOF body

    [[subjects]]
    name = "s01"                      # unique
    mass = 72.6                       # kg
    height = 1.8034                   # m
    static = "s01_static.trc"         # optional static trial
    leg = ["inverse_s01.toml"]        # leg: inverse problem files (points, options, side),
                                      # one per analysed side; their [trial] files, mass,
                                      # height and static are replaced by the trial's
    marker_map = "markers_s01.toml"   # fullbody: the marker map
    sex = "male"                      # fullbody: de Leva segments (default male)

    [[trials]]
    subject = "s01"
    condition = "barefoot"
    markers = "s01/walk*.trc"         # a file, a glob, or a list of files/globs
    grf = "{stem}_grf.mot"            # beside each marker file ({stem}: its name without
                                      # extension); omit for C3D (plates inside)

Every bad input raises one :class:`InputError` naming the file, key and line.
"""

from __future__ import annotations

import dataclasses
import glob
import hashlib
import json
import re
from dataclasses import dataclass
from pathlib import Path

from predgait import __version__
from predgait.data.bundled import bundled_path
from predgait.dynamics.inverse_options import InverseOptions
from predgait.errors import InputError
from predgait.problemfile import Table, load_problem

ANALYSES = ("leg", "fullbody")


@dataclass(frozen=True)
class TrialJob:
    """One trial to analyse (picklable: it travels to the Dask workers).

    ``legs``: the leg inverse options per side (the trial's files in them); ``fullbody``:
    the full-body settings (files, marker map, mass, height, sex, static) or None.
    """

    id: str
    subject: str
    condition: str
    markers: Path
    grf: Path | None
    legs: tuple[InverseOptions, ...]
    fullbody: dict | None
    digest: str


@dataclass(frozen=True)
class Dataset:
    """A checked dataset file: its name, source file and trials in file order."""

    name: str
    path: Path
    trials: tuple[TrialJob, ...]


def _path(table: Table, key: str, value: str | None = None) -> Path:
    value = table.get(key, str) if value is None else value
    if value.startswith("bundled:"):
        return bundled_path(value.removeprefix("bundled:"))
    return (table.path.parent / value) if not Path(value).is_absolute() else Path(value)


def _file(table: Table, key: str) -> Path | None:
    if not table.has(key):
        return None
    path = _path(table, key)
    if not path.is_file():
        raise table.error(key, f"{path}: file not found.")
    return path


def _subject(table: Table, analyses: tuple[str, ...]) -> dict:
    """One ``[[subjects]]`` row: name, mass, height, static, legs, full-body settings."""
    table.check_keys(("name", "mass", "height", "static", "leg", "marker_map", "sex", "model"))
    row = {"name": table.get("name", str),
           "mass": table.number("mass", low=20, high=300, unit="kg"),
           "height": table.number("height", None, low=0.5, high=2.5, unit="m"),
           "static": _file(table, "static"), "model": _file(table, "model"), "legs": (),
           "fullbody": None}
    if not re.fullmatch(r"[\w.+-]+", row["name"]):
        raise table.error("name", f"{row['name']!r}: use letters, digits, '.', '-', '_'.")
    if "leg" in analyses:
        from predgait.workflows.inverse_io import options_from_problem

        if not table.has("leg"):
            raise table.error("leg", "the leg analysis needs the subject's inverse problem "
                                     "files (points and options), e.g. leg = "
                                     "[\"inverse_subject01.toml\"].")
        legs = []
        for value in table.strings("leg"):
            path = _path(table, "leg", value)
            if not path.is_file():
                raise table.error("leg", f"{path}: file not found.")
            legs.append(options_from_problem(load_problem(path)))
        if len({o.side for o in legs}) < len(legs):
            raise table.error("leg", "two problem files for the same side.")
        row["legs"] = tuple(legs)
    if "fullbody" in analyses:
        if not table.has("marker_map") or row["height"] is None:
            raise table.error("marker_map", "the fullbody analysis needs the subject's "
                                            "marker_map and height.")
        sex = table.get("sex", str, "male")
        if sex not in ("male", "female"):
            raise table.error("sex", f"'{sex}' is not one of: male, female.")
        row["fullbody"] = {"marker_map": _file(table, "marker_map"), "sex": sex}
    return row


def _marker_files(table: Table) -> list[Path]:
    """The marker files of a ``[[trials]]`` row: a file, a glob or a list of them."""
    raw = table.data.get("markers")
    values = (table.strings("markers") if isinstance(raw, list)
              else (table.get("markers", str),))
    if not values:
        raise table.error("markers", "names no trial; give a file, a glob or a list.")
    files: list[Path] = []
    for value in values:
        if value.startswith("bundled:"):
            files.append(_path(table, "markers", value))
            continue
        pattern = str(_path(table, "markers", value))
        found = sorted(Path(p) for p in glob.glob(pattern) if Path(p).is_file())
        if not found:
            raise table.error("markers", f"'{value}' matches no file (looked for {pattern}).")
        files.extend(found)
    return files


def _grf(table: Table, markers: Path) -> Path | None:
    if not table.has("grf"):
        return None
    value = table.get("grf", str)
    if "{stem}" in value:
        path = markers.parent / value.replace("{stem}", markers.stem)
    else:
        path = _path(table, "grf")
    if not path.is_file():
        raise table.error("grf", f"{path}: file not found (ground reactions of {markers.name}).")
    return path


def digest(files, settings) -> str:
    """SHA-256 of the input files' bytes, the settings (JSON) and predgait's version."""
    sha = hashlib.sha256(__version__.encode())
    for path in files:
        if path is not None:
            sha.update(Path(path).read_bytes())
            xml = Path(path).with_suffix(".xml")
            if Path(path).suffix.lower() == ".mot" and xml.is_file():
                sha.update(xml.read_bytes())   # the plates' names beside a GRF file
    sha.update(json.dumps(settings, sort_keys=True, default=str).encode())
    return sha.hexdigest()


def _job(subject: dict, condition: str, markers: Path, grf: Path | None) -> TrialJob:
    legs = tuple(dataclasses.replace(o, markers=markers, grf=grf, static=subject["static"],
                                     mass=subject["mass"], height=subject["height"],
                                     model=subject["model"] or o.model)
                 for o in subject["legs"])
    body = None
    if subject["fullbody"] is not None:
        body = {**subject["fullbody"], "files": [markers] + ([grf] if grf else []),
                "mass": subject["mass"], "height": subject["height"],
                "static": subject["static"]}
    files = [markers, grf, subject["static"], subject["model"],
             *(o.model for o in legs), body and body["marker_map"]]
    settings = {"legs": [dataclasses.asdict(o) | {"markers": "", "grf": "", "static": "",
                                                  "model": ""} for o in legs],
                "fullbody": body and {k: v for k, v in body.items()
                                      if k not in ("files", "static", "marker_map")}}
    ident = re.sub(r"[^\w.+-]", "_", f"{subject['name']}__{condition}__{markers.stem}")
    return TrialJob(id=ident, subject=subject["name"], condition=condition, markers=markers,
                    grf=grf, legs=legs, fullbody=body, digest=digest(files, settings))


def read_dataset(path: str | Path, *, first: int | None = None) -> Dataset:
    """Read and check a dataset file (see the module docstring).

    ``first``: read only the file's first trials, as many (the same jobs the whole file
    gives for them; the checks of the later trials are not made).

    Raises:
        InputError: no trial, a glob matching nothing, a trial whose subject has no row,
            two subjects (or two trials) with the same name, a missing file, bad values.
    """
    table = load_problem(path)
    table.check_keys(("name", "analyses", "subjects", "trials"))
    analyses = table.strings("analyses", ("leg",))
    for name in analyses:
        if name not in ANALYSES:
            raise table.error("analyses", f"'{name}' is not one of: {', '.join(ANALYSES)}.")
    if not analyses:
        raise table.error("analyses", f"name at least one of: {', '.join(ANALYSES)}.")
    subjects: dict[str, dict] = {}
    for row in table.tables("subjects"):
        subject = _subject(row, tuple(analyses))
        if subject["name"] in subjects:
            raise row.error("name", f"two subjects are named '{subject['name']}'; subject "
                                    "names must be unique.")
        subjects[subject["name"]] = subject
    rows = table.tables("trials")
    if not rows:
        raise InputError(f"{path}: the dataset names no trial; add [[trials]] rows (subject, "
                         "condition, markers).")
    jobs: list[TrialJob] = []
    for row in rows:
        row.check_keys(("subject", "condition", "markers", "grf"))
        name = row.get("subject", str)
        if name not in subjects:
            known = ", ".join(subjects) or "none"
            raise row.error("subject", f"'{name}' has no [[subjects]] row (subjects: {known}).")
        condition = row.get("condition", str, "default")
        for markers in _marker_files(row):
            if first is not None and len(jobs) >= first:
                break
            jobs.append(_job(subjects[name], condition, markers, _grf(row, markers)))
    seen: dict[str, TrialJob] = {}
    for job in jobs:
        if job.id in seen:
            raise InputError(f"{path}: {job.markers} and {seen[job.id].markers} are both trial "
                             f"'{job.id}' (same subject, condition and file name); rename one.")
        seen[job.id] = job
    name = table.get("name", str, Path(path).stem)
    return Dataset(name=name, path=Path(path), trials=tuple(jobs))
