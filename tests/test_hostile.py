"""The host treats every FMU and file as untrusted. Each hostile FMU or input is made here (zip
files written by the test, a C library compiled by it); each case asserts what the user sees:
the exit status, one bounded message, and the files on disk before and after."""
import os
import re
import shutil
import signal
import subprocess
import time
import zipfile
from pathlib import Path

import pytest

from conftest import cli_path, fmu_path

EXIT_BAD_INPUT = 2


def run(*args, cwd=None):
    return subprocess.run([cli_path(), *map(str, args)], capture_output=True, text=True,
                          timeout=300, cwd=cwd)


def rewrite_fmu(src, dst, edit_md=None, extra=None):
    """Copy of the FMU `src` with modelDescription.xml edited and extra entries added."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml" and edit_md:
                data = edit_md(data.decode()).encode()
            zout.writestr(item, data)
        for name, data in (extra or {}).items():
            zout.writestr(name, data)
    return dst


def data_csv(path, rows=30):
    path.write_text("time,force,x\n" + "".join(f"{k * 1e-3},0,0.01\n" for k in range(rows)))
    return path


def assert_one_bounded_message(res, *fragments):
    assert res.returncode == EXIT_BAD_INPUT, (res.returncode, res.stdout, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and len(lines[0]) < 400, res.stderr[:1000]
    for f in fragments:
        assert f in lines[0], lines[0]


def test_a_model_identifier_that_is_a_path_loads_nothing_from_outside(tmp_path):
    """modelIdentifier = absolute path of a library outside the FMU whose constructor writes a
    marker: simulate, validate and gap refuse the FMU and the library is never loaded."""
    if not shutil.which("gcc"):
        pytest.fail("gcc is needed to build the outside library")
    marker = tmp_path / "LOADED"
    c = tmp_path / "evil.c"
    c.write_text('#include <stdio.h>\n__attribute__((constructor)) static void hit(void) '
                 f'{{ FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}\n')
    subprocess.run(["gcc", "-shared", "-fPIC", "-o", tmp_path / "evil.so", c], check=True)
    evil_id = str(tmp_path / "evil")
    fmu = rewrite_fmu(fmu_path("Oscillator"), tmp_path / "evil.fmu",
                      lambda md: md.replace('modelIdentifier="Oscillator"',
                                            f'modelIdentifier="{evil_id}"'))
    data = data_csv(tmp_path / "d.csv")
    for args in (["simulate", fmu, "--data", data, "--out", tmp_path / "o.csv"],
                 ["gap", fmu, "--data", data, "--out", tmp_path / "g"],
                 ["validate", fmu]):
        res = run(*args)
        assert res.returncode in (1, EXIT_BAD_INPUT), res.stderr
        assert "C identifier" in res.stderr + res.stdout, (args[0], res.stderr, res.stdout)
        assert not marker.exists(), f"{args[0]} loaded a library from outside the FMU"


def test_an_fmi2_description_relabelled_fmi3_is_read_as_fmi3(tmp_path):
    fmu = rewrite_fmu(fmu_path("Oscillator"), tmp_path / "fmi3.fmu",
                      lambda md: md.replace('fmiVersion="2.0"', 'fmiVersion="3.0"'))
    data = data_csv(tmp_path / "d.csv")
    # validate reports the unreadable FMI 3.0 description as its finding (exit 1)
    res = run("validate", fmu)
    assert res.returncode == 1, (res.returncode, res.stdout, res.stderr)
    assert "[model-description-xml]" in res.stdout, res.stdout
    assert "lacks the required attribute instantiationToken" in res.stdout, res.stdout
    # simulate and gap read it as FMI 3.0: an FMI 2.0 description relabelled lacks what 3.0
    # requires
    for args in (["simulate", fmu, "--data", data, "--out", tmp_path / "o.csv"],
                 ["gap", fmu, "--data", data, "--out", tmp_path / "g"]):
        assert_one_bounded_message(run(*args), "lacks the required attribute instantiationToken")


LONG = 50_000


def overlong_description(kind):
    """An FMI 2.0 description whose error quotes a text of LONG characters the file holds."""
    head = '<?xml version="1.0"?><fmiModelDescription fmiVersion="2.0" modelName="m" guid="g">'
    cs = '<CoSimulation modelIdentifier="m"/>'
    body = {
        "start": (f'{cs}<ModelVariables><ScalarVariable name="{"n" * LONG}" valueReference="1">'
                  f'<Real start="{"x" * LONG}"/></ScalarVariable></ModelVariables>'),
        "type element": (f'{cs}<TypeDefinitions><SimpleType name="t"><{"Q" * LONG}/>'
                         '</SimpleType></TypeDefinitions>'),
        "dependency": (f'{cs}<ModelVariables><ScalarVariable name="y" valueReference="1" '
                       'causality="output"><Real/></ScalarVariable></ModelVariables>'
                       f'<ModelStructure><Outputs><Unknown index="1" dependencies="{"z" * LONG}"/>'
                       '</Outputs></ModelStructure>'),
        "entity": f'<{"E" * LONG} a="&{"e" * LONG};"/>',
        "end tag": f'<{"b" * LONG}>',
    }[kind]
    return head + body + "</fmiModelDescription>"


@pytest.mark.parametrize("kind", ["start", "type element", "dependency", "entity", "end tag"])
def test_a_description_quoting_an_overlong_text_gives_bounded_messages(tmp_path, kind):
    """Every text of the file a message quotes is shortened: simulate answers one bounded
    line, validate's findings stay lines of a report, not copies of the file."""
    fmu = tmp_path / "long.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml", overlong_description(kind))
    data = tmp_path / "d.csv"
    data.write_text("time\n0\n1\n")
    assert_one_bounded_message(run("simulate", fmu, "--data", data, "--out", tmp_path / "o.csv"),
                               "long.fmu!modelDescription.xml:")
    res = run("validate", fmu)
    assert res.returncode == 1, (res.returncode, res.stdout[:1000], res.stderr[:1000])
    assert "[model-description-xml]" in res.stdout, res.stdout[:1000]
    assert max(map(len, res.stdout.splitlines())) < 1000, res.stdout[:1000]


def test_an_archive_entry_escaping_with_an_overlong_name_is_named_shortened(tmp_path):
    fmu = tmp_path / "esc.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("../" + "a" * LONG, "x")
        z.writestr("modelDescription.xml", overlong_description("start"))
    res = run("validate", fmu)
    assert res.returncode == 1, (res.returncode, res.stdout[:1000], res.stderr[:1000])
    assert "escapes the archive" in res.stdout, res.stdout[:1000]
    assert max(map(len, res.stdout.splitlines())) < 1000, res.stdout[:1000]


@pytest.mark.parametrize("which", ["data", "fmu"])
def test_out_equal_to_an_input_is_refused_and_the_input_kept(tmp_path, which):
    fmu = tmp_path / "m.fmu"
    shutil.copy(fmu_path("Oscillator"), fmu)
    data = data_csv(tmp_path / "d.csv")
    target = {"data": data, "fmu": fmu}[which]
    before = target.read_bytes()
    # the same file under another name
    res = run("simulate", fmu, "--data", data, "--out", tmp_path / "." / target.name)
    assert_one_bounded_message(res, "refusing to overwrite")
    assert target.read_bytes() == before


def test_gap_report_directory_holding_an_input_named_like_a_report_is_refused(tmp_path):
    data = data_csv(tmp_path / "report.json")
    before = data.read_bytes()
    res = run("gap", fmu_path("Oscillator"), "--data", data, "--out", tmp_path)
    assert_one_bounded_message(res, "would overwrite the input")
    assert data.read_bytes() == before


def test_simulate_output_is_replaced_whole_or_not_at_all(tmp_path):
    out = tmp_path / "o.csv"
    out.write_text("previous good result\n")
    res = run("simulate", fmu_path("Oscillator"), "--data", data_csv(tmp_path / "d.csv"),
              "--set", "fail_at=0.01", "--out", out)
    assert res.returncode != 0
    assert out.read_text() == "previous good result\n"
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".partial")]


def test_holdout_zero_is_refused(tmp_path):
    res = run("gap", fmu_path("Oscillator"), "--data", data_csv(tmp_path / "d.csv"),
              "--out", tmp_path / "g", "--holdout", "0")
    assert_one_bounded_message(res, "--holdout 0")


def test_setting_an_output_is_refused(tmp_path):
    res = run("simulate", fmu_path("Oscillator"), "--data", data_csv(tmp_path / "d.csv"),
              "--set", "x=1", "--out", tmp_path / "o.csv")
    assert_one_bounded_message(res, "'x' is an output", "only parameters and inputs")


def test_a_guid_the_binary_refuses_is_a_bad_fmu(tmp_path):
    fmu = rewrite_fmu(fmu_path("Oscillator"), tmp_path / "g.fmu",
                      lambda md: re.sub(r'guid="[^"]*"', 'guid="{00000000-0000-0000-0000-000000000000}"', md))
    res = run("simulate", fmu, "--data", data_csv(tmp_path / "d.csv"), "--out", tmp_path / "o.csv")
    assert_one_bounded_message(res, "fmi2Instantiate")


def test_a_zip_bomb_is_refused_before_it_fills_the_disk(tmp_path):
    """64 MiB of zeros deflate to 64 kB (ratio > 1000): refused, naming the entry and the limit."""
    fmu = rewrite_fmu(fmu_path("Oscillator"), tmp_path / "bomb.fmu",
                      extra={"resources/zeros.bin": b"\0" * (64 << 20)})
    res = run("simulate", fmu, "--data", data_csv(tmp_path / "d.csv"), "--out", tmp_path / "o.csv")
    assert_one_bounded_message(res, "resources/zeros.bin", "1000x")
    # validate reports it as a finding of the archive
    res = run("validate", fmu)
    assert res.returncode == 1 and "resources/zeros.bin" in res.stdout


def test_a_huge_cell_gets_a_short_message_with_its_location(tmp_path):
    data = tmp_path / "d.csv"
    data.write_bytes(b"time,force,x\n0,0,0\n0.001," + b"7" * (2 << 20) + b",0\n")
    res = run("simulate", fmu_path("Oscillator"), "--data", data, "--out", tmp_path / "o.csv")
    assert_one_bounded_message(res, "d.csv:3", "line longer than")


def test_control_bytes_in_a_cell_are_escaped_in_the_message(tmp_path):
    data = tmp_path / "d.csv"
    data.write_bytes(b"time,force,x\n0,0,0\n0.001,1\x00\x1b[31mred,0\n")
    res = run("simulate", fmu_path("Oscillator"), "--data", data, "--out", tmp_path / "o.csv")
    assert_one_bounded_message(res, "d.csv:3")
    assert "\x00" not in res.stderr and "\x1b" not in res.stderr


@pytest.mark.parametrize("value", ["1e300", "-1e300", "1e101"])
def test_data_too_large_to_compute_with_is_refused(tmp_path, value):
    """Squares of ±1e300 overflow: refused with the place, never an rmse of inf or null."""
    data = tmp_path / "d.csv"
    data.write_text("time,force,x\n0,0,0\n0.001,0,0\n0.002,0," + value + "\n0.003,0,0\n")
    out = tmp_path / "g"
    res = run("gap", fmu_path("Oscillator"), "--data", data, "--out", out)
    assert_one_bounded_message(res, "d.csv:4:3", "beyond ±1e100")
    assert not (out / "report.json").exists()
    res = run("simulate", fmu_path("Oscillator"), "--data", data, "--out", tmp_path / "o.csv")
    assert_one_bounded_message(res, "d.csv:4:3", "beyond ±1e100")


def failing_copy(tmp_path, *defines):
    """Oscillator whose fmi2DoStep crashes (or hangs, with -DHANG) from t = 0.01 s on: the
    crash shim of tests/drivers/broken forwards every other call to the real binary."""
    if shutil.which("gcc") is None:
        pytest.skip("gcc not installed")
    repo = Path(__file__).resolve().parent.parent
    so = tmp_path / "shim.so"
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", '-DMODEL_ID="Oscillator"', "-DFAIL_AT=0.01",
                    *defines, "-o", str(so), str(repo / "tests/drivers/broken/crash_shim.c"), "-ldl"],
                   check=True)
    binary = "binaries/linux64/Oscillator.so"
    dst = tmp_path / ("hang.fmu" if defines else "crash.fmu")
    with zipfile.ZipFile(fmu_path("Oscillator")) as zin, \
            zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == binary:
                zout.writestr("binaries/linux64/real_Oscillator.so", data)
                data = so.read_bytes()
            zout.writestr(item.filename, data)
    return dst


def run_in(tmp, *args, **kw):
    """The CLI with TMPDIR=tmp, so that the test sees every temporary file it makes."""
    tmp.mkdir(exist_ok=True)
    env = dict(os.environ, TMPDIR=str(tmp))
    return subprocess.run([cli_path(), *map(str, args)], capture_output=True, text=True,
                          timeout=120, env=env, **kw)


@pytest.mark.parametrize("command", ["simulate", "gap"])
def test_an_fmu_crashing_in_do_step_is_reported_with_time_and_nothing_left(tmp_path, command):
    fmu = failing_copy(tmp_path)
    data = data_csv(tmp_path / "d.csv", rows=50)
    out = tmp_path / ("o.csv" if command == "simulate" else "g")
    extra = ["--fit", "stiffness"] if command == "gap" else []
    res = run_in(tmp_path / "tmp", command, fmu, "--data", data, "--out", out, *extra)
    assert_one_bounded_message(res, "crashed (SIGSEGV) in fmi2DoStep at t = 0.01")
    assert not out.exists()
    assert list((tmp_path / "tmp").iterdir()) == []


def test_an_fmu_hanging_in_do_step_is_stopped_after_the_timeout(tmp_path):
    fmu = failing_copy(tmp_path, "-DHANG")
    data = data_csv(tmp_path / "d.csv", rows=50)
    t0 = time.monotonic()
    res = run_in(tmp_path / "tmp", "simulate", fmu, "--data", data, "--out", tmp_path / "o.csv",
                 "--timeout", "1")
    assert time.monotonic() - t0 < 30
    assert_one_bounded_message(res, "did not return from fmi2DoStep at t = 0.01", "within 1 s")
    assert not (tmp_path / "o.csv").exists()
    assert list((tmp_path / "tmp").iterdir()) == []


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_run_removes_its_temporary_files(tmp_path, sig):
    fmu = failing_copy(tmp_path, "-DHANG")
    data = data_csv(tmp_path / "d.csv", rows=50)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    # its own process group, as a shell job: Ctrl-C reaches the supervisor and its worker
    p = subprocess.Popen([cli_path(), "simulate", fmu, "--data", data, "--out", tmp_path / "o.csv",
                          "--timeout", "0"], env=dict(os.environ, TMPDIR=str(tmp)),
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 20
    while not any(tmp.rglob("*.so")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert any(tmp.rglob("*.so")), "the FMU was never extracted"
    time.sleep(0.3)  # inside the hanging fmi2DoStep now
    os.killpg(p.pid, sig)
    _, err = p.communicate(timeout=20)
    assert p.returncode == 130, (p.returncode, err)
    assert "interrupted" in err and len(err.strip().splitlines()) == 1, err
    assert list(tmp.iterdir()) == []
    assert not (tmp_path / "o.csv").exists()


def test_ctrl_c_while_simulate_writes_its_output_leaves_no_partial_file(toy, tmp_path):
    """A run writing a large result (2 million rows, some 50 MB), SIGINT to its process group
    (Ctrl-C in a shell) once the temporary output file exists next to the output: the worker
    dies while writing; the supervisor removes the file the worker listed before creating it."""
    out = tmp_path / "o.csv"
    dahlquist = toy("Dahlquist")
    p = subprocess.Popen([cli_path(), "simulate", dahlquist, "--stop", "2", "--step", "1e-6",
                          "--out", out], stderr=subprocess.PIPE, text=True,
                         start_new_session=True)
    deadline = time.monotonic() + 60
    partial = []
    while not partial and p.poll() is None and time.monotonic() < deadline:
        partial = [q for q in tmp_path.iterdir() if q.name.endswith(".partial")]
        time.sleep(0.002)
    assert partial, "the temporary output file was never seen"
    time.sleep(0.05)  # writing now
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=20)
    assert p.returncode == 130, (p.returncode, err)
    assert list(tmp_path.iterdir()) == [], list(tmp_path.iterdir())


def test_validate_leaves_no_temporary_files_even_when_the_probe_crashes(tmp_path):
    """The probe's child crashes (on the calls an importer must not make: notes, exit 0, as FMI
    2.0.4 section 4.2.4 leaves their outcome to the FMU); its temporary directory goes all the same."""
    fmu = failing_copy(tmp_path)
    res = run_in(tmp_path / "tmp", "validate", fmu)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "the FMU crashed" in res.stdout, res.stdout
    assert list((tmp_path / "tmp").iterdir()) == []


def test_a_symbolic_link_entry_is_refused_naming_the_entry_not_a_temporary_path(tmp_path):
    link = zipfile.ZipInfo("resources/passwd")
    link.create_system = 3  # unix
    link.external_attr = (0o120777 << 16)  # S_IFLNK
    fmu = tmp_path / "link.fmu"
    with zipfile.ZipFile(fmu_path("Oscillator")) as zin, \
            zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            zout.writestr(item, zin.read(item.filename))
        zout.writestr(link, "/etc/passwd")
    res = run_in(tmp_path / "tmp", "simulate", fmu, "--data", data_csv(tmp_path / "d.csv"),
                 "--out", tmp_path / "o.csv")
    assert_one_bounded_message(res, "resources/passwd", "symbolic link")
    assert str(tmp_path / "tmp") not in res.stderr and "fmu-host-" not in res.stderr


def test_a_run_that_would_record_more_than_memory_allows_is_refused(tmp_path):
    """1e8 communication points of 2 outputs: refused before anything is allocated."""
    res = run("simulate", fmu_path("Oscillator"), "--stop", "10", "--step", "1e-7",
              "--out", tmp_path / "o.csv")
    assert_one_bounded_message(res, "would record", "use a larger step")
    assert not (tmp_path / "o.csv").exists()
