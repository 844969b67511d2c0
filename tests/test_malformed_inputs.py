"""Malformed inputs made from the real files by seeded mutation, against every command.

Each case copies the real inputs (problem files, the subject01 TRC/MOT, walking5.c3d, a
segment table, the leg URDF) into a fresh folder, breaks one of them in one way (not
UTF-8, empty, header only, truncated, a duplicate label, a wrong type or value, an
unknown key, ...), runs the command in process and checks the promise of the README:
exit 2, exactly one line ``predgait: error: ...`` and nothing else on stderr (no
traceback, no warning, no C++ message), nothing written, every input unchanged.
The cases are generated with a fixed seed, so a failure names a reproducible case.
"""

from __future__ import annotations

import hashlib
import random
import re
import shutil
import signal
from dataclasses import dataclass
from pathlib import Path

import pytest

from predgait.cli import main

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data"
S01 = DATA / "opensim_subject01_walk1"
C3D = DATA / "opensim_walking5_c3d" / "walking5.c3d"
SEED = 20261130
LIMIT_S = 20  # a case still running after this accepted its bad input

#: Markers of the walk (not joint centres, but enough for the files to be read in full).
LEG_MARKERS = "hip=R.ASIS,knee=R.Thigh.Rear,ankle=R.Shank.Rear,heel=R.Heel,toe=R.Toe.Tip"
C3D_MARKERS = "hip=RHJC,knee=RKJC,ankle=RAJC,heel=RCAL,toe=RMT2"
SEGMENTS = ("segment,mass_kg,length_m,com_from_proximal,inertia_kg_m2\n"
            "foot,1.05,0.26,0.5,0.0044\nshank,3.37,0.43,0.433,0.0504\n"
            "thigh,7.26,0.43,0.433,0.1330\n")

#: Problem files and the command line that reads each ({} is the file).
PROBLEMS = {
    "rod.toml": ["simulate", "{}"],
    "collapse.toml": ["simulate", "{}"],
    "resynthesis.toml": ["simulate", "{}"],
    "gait7_contact.toml": ["simulate", "{}"],
    "fullbody_resynthesis.toml": ["simulate", "{}"],
    "knee_fit.toml": ["solve", "{}"],
    "torque_correction.toml": ["solve", "{}"],
    "feedback_gains.toml": ["solve", "{}"],
    "torque_feedback.toml": ["solve", "{}"],
    "scenario_stiff_knee.toml": ["scenario", "{}"],
    "scenario_cast_afo.toml": ["scenario", "{}"],
    "scenario_knee_arthrodesis.toml": ["scenario", "{}"],
    "sweep_knee_stiffness.toml": ["sweep", "{}", "--workers", "1"],
    "batch_subject01.toml": ["batch", "{}", "--workers", "1"],
    "inverse_subject01.toml": ["inverse", "{}"],
    "inverse_winter_a1.toml": ["inverse", "{}"],
    "inverse_subject01_left.toml": ["inverse", "{}"],
    "inverse_walking5.toml": ["inverse", "{}"],
    "passive_decomposition.toml": ["solve", "{}"],
    "passive_shooting.toml": ["solve", "{}"],
    "passive_swing.toml": ["solve", "{}"],
    "passive_shooting_nonlinear.toml": ["solve", "{}"],
    "resynthesis_fig4_2_9.toml": ["simulate", "{}"],
    "markers_fullbody_subject01.toml": [
        "inverse", "s01/subject01_walk1.trc", "--grf", "s01/subject01_walk1_grf.mot",
        "--mass", "72.6", "--height", "1.8034", "--model", "fullbody", "--marker-map", "{}"],
}

#: Data files and the command line that reads each.
DATA_COMMANDS = {
    "s01/subject01_walk1.trc": ["inverse", "{}", "--grf", "s01/subject01_walk1_grf.mot",
                                "--mass", "72.6", "--markers", LEG_MARKERS],
    "s01/subject01_walk1_grf.mot": ["inverse", "s01/subject01_walk1.trc", "--grf", "{}",
                                    "--mass", "72.6", "--markers", LEG_MARKERS],
    "markers.csv": ["inverse", "{}", "--mass", "72.6", "--markers",
                    "hip=HIP,knee=KNEE,ankle=ANKLE,toe=TOE"],
    "segments.csv": ["model", "build", "leg", "--segments", "{}", "-o", "out.urdf"],
    "leg.urdf": ["model", "show", "{}"],
}


@dataclass(frozen=True)
class Case:
    """One malformed input: which file, how it is broken, the command that reads it."""

    name: str
    target: str
    content: bytes | None  # new bytes of ``target`` (None: unchanged)
    argv: tuple[str, ...]


def _lines_with(text: str, pattern: str) -> list[int]:
    return [i for i, line in enumerate(text.splitlines()) if re.match(pattern, line)]


def _replace_line(text: str, index: int, line: str) -> str:
    lines = text.splitlines()
    lines[index] = line
    return "\n".join(lines) + "\n"


def toml_mutations(text: str, rng: random.Random) -> list[tuple[str, bytes]]:
    """Broken versions of a TOML problem file, each one certainly invalid."""
    raw = text.encode()
    lines = text.splitlines()
    values = _lines_with(text, r"^\s*[\"A-Za-z_][\w.\"]*\s*=\s*\S")
    numbers = _lines_with(text, r"^\s*[\"A-Za-z_][\w.\"]*\s*=\s*-?[\d.]+(e-?\d+)?\s*(#.*)?$")
    strings = _lines_with(text, r"^\s*[\"A-Za-z_][\w.\"]*\s*=\s*\"[^\"]*\"\s*(#.*)?$")
    lists = _lines_with(text, r"^\s*[\"A-Za-z_][\w.\"]*\s*=\s*\[.*\]\s*(#.*)?$")
    sections = _lines_with(text, r"^\s*\[[^\[]")
    out = []
    cut = rng.randrange(len(raw))
    out.append(("latin1", raw[:cut] + "é".encode("latin-1") + raw[cut:]))
    out.append(("garbage", bytes(rng.randrange(128, 256) for _ in range(200))))
    out.append(("nul", raw[:cut] + b"\x00" + raw[cut:]))
    out.append(("empty", b""))
    out.append(("syntax", raw[:cut] + b"\n= = broken\n"))
    index = rng.choice(values)
    out.append(("duplicate_key", _replace_line(text, index, lines[index] + "\n" + lines[index])
                .encode()))
    where = rng.choice(sections) if sections else -1
    unknown = "bogus_key_x = 1"
    if where >= 0:
        out.append(("unknown_key", _replace_line(text, where, lines[where] + "\n" + unknown)
                    .encode()))
    else:
        out.append(("unknown_key", (unknown + "\n" + text).encode()))
    if numbers:
        index = rng.choice(numbers)
        key = lines[index].split("=", 1)[0]
        out.append(("number_as_string", _replace_line(text, index, f'{key}= "abc"').encode()))
        out.append(("number_nan", _replace_line(text, index, f"{key}= nan").encode()))
        out.append(("number_huge", _replace_line(text, index, f"{key}= -1e308").encode()))
        out.append(("number_as_table", _replace_line(text, index, f"{key}= {{ a = 1 }}")
                    .encode()))
    if strings:
        index = rng.choice(strings)
        key = lines[index].split("=", 1)[0]
        out.append(("string_as_number", _replace_line(text, index, f"{key}= 5").encode()))
        out.append(("string_as_list", _replace_line(text, index, f"{key}= [1, 2]").encode()))
    if lists:
        index = rng.choice(lists)
        key = lines[index].split("=", 1)[0]
        out.append(("list_mixed", _replace_line(text, index, f'{key}= [1.0, "x", true]')
                    .encode()))
        out.append(("list_as_number", _replace_line(text, index, f"{key}= 5").encode()))
    return out


def trc_mutations(text: str, rng: random.Random) -> list[tuple[str, bytes]]:
    """Broken versions of a TRC file."""
    lines = text.splitlines(keepends=True)
    head, body = lines[:5], lines[5:]
    values = head[2].split("\t")
    dup = lines[3].replace("\tL.ASIS\t", "\tR.ASIS\t", 1)
    row = rng.randrange(len(body))
    fields = body[row].split("\t")
    fields[rng.randrange(2, len(fields) - 1)] = "abc"
    cut = rng.randrange(1, len(body) - 1)
    huge = body[row].split("\t")
    huge[rng.randrange(2, len(huge) - 1)] = "1e308"
    return [
        ("huge_value", "".join(head + body[:row] + ["\t".join(huge)] + body[row + 1:]).encode()),
        ("latin1", "".join(head).encode() + "é".encode("latin-1") + "".join(body).encode()),
        ("empty", b""),
        ("header_only", "".join(head).encode()),
        ("truncated_rows", "".join(head + body[:cut]).encode()),
        ("truncated_mid_file", text.encode()[: rng.randrange(100, len(text) // 2)]),
        ("duplicate_marker", "".join(head[:3] + [dup] + head[4:] + body).encode()),
        ("non_numeric", "".join(head + body[:row] + ["\t".join(fields)] + body[row + 1:])
         .encode()),
        ("one_row", "".join(head[:2] + ["\t".join([*values[:2], "1", *values[3:]])]
                            + head[3:] + body[:1]).encode()),
    ]


def storage_mutations(text: str, rng: random.Random) -> list[tuple[str, bytes]]:
    """Broken versions of an OpenSim .mot file."""
    lines = text.splitlines(keepends=True)
    end = next(i for i, ln in enumerate(lines) if ln.strip() == "endheader")
    head, labels, body = lines[: end + 1], lines[end + 1], lines[end + 2:]
    columns = labels.rstrip("\n").split("\t")
    dup = "\t".join(columns[:2] + [columns[1]] + columns[3:]) + "\n"
    row = rng.randrange(len(body))
    fields = body[row].split("\t")
    fields[rng.randrange(1, len(fields) - 1)] = "x1"
    constant = [f"{0.5}\t" + ln.split("\t", 1)[1] for ln in body]
    huge = body[row].split("\t")
    huge[1] = "-1e308"
    backwards = body[:]
    backwards[row], backwards[row - 1] = backwards[row - 1], backwards[row]
    return [
        ("latin1", "".join(head).encode() + b"\xe9\xff" + "".join([labels, *body]).encode()),
        ("empty", b""),
        ("header_only", "".join(head + [labels]).encode()),
        ("one_row", "".join(head + [labels] + body[:1]).encode()),
        ("truncated_mid_line", "".join(head + [labels] + body[:row]).encode()
         + body[row].encode()[: len(body[row]) // 2]),
        ("duplicate_column", "".join(head + [dup] + body).encode()),
        ("non_numeric", "".join(head + [labels] + body[:row] + ["\t".join(fields)]
                                + body[row + 1:]).encode()),
        ("constant_time", "".join(head + [labels] + constant).encode()),
        ("huge_force", "".join(head + [labels] + body[:row] + ["\t".join(huge)]
                               + body[row + 1:]).encode()),
        ("time_backwards", "".join(head + [labels] + backwards).encode()),
        ("no_endheader", "".join(head[:-1] + [labels] + body).encode()),
    ]


def markers_csv(rng: random.Random) -> str:
    """A synthetic marker CSV (four markers, 100 Hz) to break."""
    rows = ["time,HIP_x,HIP_y,HIP_z,KNEE_x,KNEE_y,KNEE_z,ANKLE_x,ANKLE_y,ANKLE_z,"
            "TOE_x,TOE_y,TOE_z"]
    for i in range(60):
        x = 0.01 * i
        rows.append(",".join(f"{v:.4f}" for v in (
            i / 100, x, 0.1, 0.9, x + 0.02, 0.1, 0.5, x, 0.1, 0.08, x + 0.15, 0.1, 0.02)))
    return "\n".join(rows) + "\n"


def csv_mutations(text: str, rng: random.Random) -> list[tuple[str, bytes]]:
    """Broken versions of a marker or segment CSV."""
    lines = text.splitlines(keepends=True)
    header, body = lines[0], lines[1:]
    labels = header.rstrip("\n").split(",")
    dup = ",".join(labels[:2] + [labels[1]] + labels[3:]) + "\n"
    row = rng.randrange(len(body))
    fields = body[row].rstrip("\n").split(",")
    fields[rng.randrange(1, len(fields))] = "abc"
    return [
        ("latin1", header.encode() + "é".encode("latin-1") + "".join(body).encode()),
        ("empty", b""),
        ("header_only", header.encode()),
        ("duplicate_column", (dup + "".join(body)).encode()),
        ("non_numeric", "".join([header, *body[:row], ",".join(fields) + "\n",
                                 *body[row + 1:]]).encode()),
        ("duplicate_row", "".join([header, *body, body[row]]).encode()),
    ]


def urdf_mutations(text: str, rng: random.Random) -> list[tuple[str, bytes]]:
    """Broken versions of a predgait URDF."""
    masses = re.findall(r'<mass value="([^"]+)"/>', text)
    mass = rng.choice(masses)
    ixx = re.findall(r'ixx="([^"]+)"', text)[0]
    return [
        ("latin1", text.encode()[:200] + b"\xe9" + text.encode()[200:]),
        ("empty", b""),
        ("truncated", text.encode()[: rng.randrange(200, len(text) - 20)]),
        ("negative_mass", text.replace(f'<mass value="{mass}"/>',
                                       f'<mass value="-{mass}"/>', 1).encode()),
        ("nan_inertia", text.replace(f'ixx="{ixx}"', 'ixx="nan"', 1).encode()),
        ("negative_inertia", text.replace(f'ixx="{ixx}"', f'ixx="-{ixx}"', 1).encode()),
        ("mass_text", text.replace(f'<mass value="{mass}"/>', '<mass value="heavy"/>', 1)
         .encode()),
        ("bad_joint_parent", re.sub(r'<parent link="(\w+)"/>', '<parent link="nowhere"/>',
                                    text, count=1).encode()),
    ]


def c3d_mutations(raw: bytes, rng: random.Random) -> list[tuple[str, bytes]]:
    """Truncations of a C3D file (inside the header, the parameters and the data)."""
    cuts = [0, 100, rng.randrange(520, 6000), rng.randrange(7000, len(raw) // 2),
            int(0.68 * len(raw)), len(raw) - 512]
    return [(f"cut_{cut}", raw[:cut]) for cut in cuts] + [
        ("not_c3d", b"this is not a c3d file\n" * 40)]


def set_cases() -> list[tuple[str, str, list[str]]]:
    """Bad ``--set`` overrides: (name, problem file, extra arguments)."""
    return [
        ("edit_number", "scenario_stiff_knee.toml", ["--set", "edit=5"]),
        ("edit_string", "scenario_stiff_knee.toml", ["--set", "edit.0.k='soft'"]),
        ("edit_index", "scenario_stiff_knee.toml", ["--set", "edit.3.k=1"]),
        ("edit_negative", "scenario_stiff_knee.toml", ["--set", "edit.0.k=-5"]),
        ("no_equals", "scenario_stiff_knee.toml", ["--set", "edit.0.k"]),
        ("window_order", "scenario_stiff_knee.toml", ["--set", "window=[1.0, 0.0]"]),
        ("step_negative", "resynthesis.toml", ["--set", "integrator.step=-1"]),
        ("iterations_zero", "resynthesis.toml", ["--set", "integrator.iterations=0"]),
        ("iterations_text", "resynthesis.toml", ["--set", "integrator.iterations=ten"]),
        ("method_unknown", "resynthesis.toml", ["--set", "integrator.method=leapfrog"]),
        ("passive_unknown", "resynthesis.toml", ["--set", "passive.knee.bogus=2"]),
        ("passive_negative", "resynthesis.toml", ["--set", "passive.knee.k=-2"]),
        ("times_negative", "resynthesis.toml", ["--set", "stability.times=[-1.0]"]),
        ("times_beyond", "resynthesis.toml", ["--set", "stability.times=[99.0]"]),
        ("times_text", "resynthesis.toml", ["--set", "stability.times=[0.1, 'x']"]),
        ("compare_numbers", "collapse.toml", ["--set", "compare=[1, 2]"]),
        ("variants_number", "resynthesis.toml", ["--set", "variants=5"]),
        ("step_study_text", "rod.toml", ["--set", "rod.step_study=[0.01, 'x']"]),
        ("nodes_zero", "knee_fit.toml", ["--set", "nodes=0"]),
        ("window_text", "knee_fit.toml", ["--set", "window=['a', 'b']"]),
        ("kind_unknown", "knee_fit.toml", ["--set", "kind='fly'"]),
    ]


#: Bad command lines over intact inputs: (name, argv); argv with its own --out or -o.
COMMAND_CASES = (
    ("report_missing_folder", ("report", "nowhere", "-o", "r.html")),
    ("report_a_file", ("report", "rod.toml", "-o", "r.html")),
    ("report_no_results", ("report", "s01", "-o", "r.html")),
    ("report_into_its_folder", ("report", "s01", "-o", "s01/r.html", "--force")),
    ("demo_over_a_folder", ("demo", "--out", "s01")),
    ("demo_over_a_file", ("demo", "--out", "rod.toml")),
    ("build_into_missing_folder", ("model", "build", "leg", "-o", "nowhere/leg.urdf")),
    ("build_over_its_segments", ("model", "build", "leg", "--segments", "segments.csv",
                                 "-o", "segments.csv", "--force")),
    ("build_over_an_existing_file", ("model", "build", "rod", "-o", "leg.urdf")),
    ("inverse_out_is_the_problem", ("inverse", "inverse_subject01.toml", "--out",
                                    "inverse_subject01.toml", "--force")),
    ("simulate_out_is_cwd", ("simulate", "rod.toml", "--out", ".", "--force")),
    ("scenario_out_holds_it", ("scenario", "s01/../scenario_stiff_knee.toml", "--out", "s01/..",
                               "--force")),
    ("sweep_no_workers", ("sweep", "sweep_knee_stiffness.toml", "--workers", "0", "--out", "r")),
    ("sweep_bad_scheduler", ("sweep", "sweep_knee_stiffness.toml", "--scheduler",
                             "not an address", "--out", "r")),
    ("solve_out_is_a_file", ("solve", "knee_fit.toml", "--out", "rod.toml", "--force")),
    ("inverse_missing_trial", ("inverse", "nowhere.trc", "--mass", "70", "--markers",
                               LEG_MARKERS, "--out", "r")),
    ("inverse_no_mass", ("inverse", "s01/subject01_walk1.trc", "--markers", LEG_MARKERS,
                         "--out", "r")),
)


def build_cases() -> list[Case]:
    """Every case, from the real files, with one seeded generator."""
    rng = random.Random(SEED)
    cases = []
    for name, argv in PROBLEMS.items():
        text = (REPO / "problems" / name).read_text()
        for how, content in toml_mutations(text, rng):
            cases.append(Case(f"{name}:{how}", name, content,
                              tuple(a.replace("{}", name) for a in argv)))
    sources = {
        "s01/subject01_walk1.trc": trc_mutations((S01 / "subject01_walk1.trc").read_text(), rng),
        "s01/subject01_walk1_grf.mot": storage_mutations(
            (S01 / "subject01_walk1_grf.mot").read_text(), rng),
        "markers.csv": csv_mutations(markers_csv(rng), rng),
        "segments.csv": csv_mutations(SEGMENTS, rng),
        "leg.urdf": urdf_mutations((REPO / "urdf" / "leg.urdf").read_text(), rng),
    }
    for target, mutations in sources.items():
        for how, content in mutations:
            argv = tuple(a.replace("{}", target) for a in DATA_COMMANDS[target])
            cases.append(Case(f"{target}:{how}", target, content, argv))
    for how, content in c3d_mutations(C3D.read_bytes(), rng):
        cases.append(Case(f"walking5.c3d:{how}", "walking5.c3d", content,
                          ("inverse", "walking5.c3d", "--mass", "72", "--markers", C3D_MARKERS)))
    for how, content in urdf_mutations((REPO / "urdf" / "leg.urdf").read_text(), rng)[3:6]:
        argv = [a.replace("{}", "s01/subject01_walk1.trc")
                for a in DATA_COMMANDS["s01/subject01_walk1.trc"]]
        cases.append(Case(f"inverse --model:{how}", "leg.urdf", content,
                          (*argv, "--model", "leg.urdf")))
    for how, problem, extra in set_cases():
        argv = PROBLEMS.get(problem, ["simulate", "{}"])
        cases.append(Case(f"--set:{how}", problem, None,
                          (*(a.replace("{}", problem) for a in argv), *extra)))
    for how, argv in COMMAND_CASES:
        cases.append(Case(f"command:{how}", "", None, argv))
    return cases


CASES = build_cases()


@pytest.fixture(scope="module")
def pristine(tmp_path_factory) -> Path:
    """The real inputs, copied once; each case works on its own copy."""
    folder = tmp_path_factory.mktemp("inputs")
    for path in (REPO / "problems").glob("*.toml"):
        shutil.copy(path, folder / path.name)
    shutil.copytree(S01, folder / "s01")
    shutil.copy(C3D, folder / "walking5.c3d")
    shutil.copy(REPO / "urdf" / "leg.urdf", folder / "leg.urdf")
    (folder / "segments.csv").write_text(SEGMENTS)
    (folder / "markers.csv").write_text(markers_csv(random.Random(SEED)))
    return folder


def _digest(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_enough_cases():
    assert len(CASES) >= 150
    assert len({c.name for c in CASES}) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_malformed_input_is_one_clear_error(case, pristine, tmp_path, capfd, monkeypatch):
    work = tmp_path / "work"
    shutil.copytree(pristine, work)
    if case.content is not None:
        (work / case.target).write_bytes(case.content)
    before = _digest(work)
    monkeypatch.chdir(work)
    argv = list(case.argv)
    if argv[0] not in ("model", "report") and "--out" not in argv:
        argv += ["--out", "result"]
    def too_long(*_):
        raise TimeoutError(f"{case.name}: still running after {LIMIT_S} s: the bad input "
                           "was accepted")

    signal.signal(signal.SIGALRM, too_long)
    signal.alarm(LIMIT_S)
    try:
        status = main(argv)
    finally:
        signal.alarm(0)
    captured = capfd.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert status == 2, (status, captured.err[-2000:], captured.out[-500:])
    assert len(lines) == 1 and lines[0].startswith("predgait: error: "), captured.err[-2000:]
    assert "Traceback" not in captured.err
    if case.content is not None:  # the message names the broken file, not something else
        assert Path(case.target).name in lines[0], lines[0]
    assert _digest(work) == before, "an input was changed or a file was written"
    assert sorted(p.name for p in work.iterdir()) == sorted(pristine_names(pristine))


def pristine_names(folder: Path) -> list[str]:
    return [p.name for p in folder.iterdir()]


SUBPROCESS_CASES = ("leg.urdf:bad_joint_parent", "walking5.c3d:cut_100",
                    "resynthesis.toml:latin1", "s01/subject01_walk1_grf.mot:huge_force")


@pytest.mark.parametrize("name", SUBPROCESS_CASES)
def test_malformed_input_in_a_real_process(name, pristine, tmp_path):
    """The same promise from a real ``predgait`` process (C++ messages on file descriptor
    2 included, exit status as the shell sees it)."""
    import subprocess
    import sys

    case = next(c for c in CASES if c.name == name)
    work = tmp_path / "work"
    shutil.copytree(pristine, work)
    (work / case.target).write_bytes(case.content)
    before = _digest(work)
    argv = [*case.argv, *([] if case.argv[0] == "model" else ["--out", "result"])]
    result = subprocess.run([sys.executable, "-m", "predgait", *argv], cwd=work,
                            capture_output=True, text=True, timeout=120)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and lines[0].startswith("predgait: error: "), result.stderr
    assert _digest(work) == before
