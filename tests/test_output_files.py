"""Files kanedyn writes for the user: complete or not there at all, never through
a name someone else put there; streams that cannot be written.

Every writer of a file the user names goes through ``kanedyn._output_files.replacing``
(a new file made by ``mkstemp`` in the target's folder, written through its
descriptor, given the mode of a new file and renamed over the target when
complete).  A full disk is a tmpfs of a few blocks (``small_disk``: root only,
skipped otherwise, saying so); a full stdout is ``/dev/full`` or a stream whose
writes fail.
"""

import ast
import errno
import io
import os
import re
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import kanedyn as kd
from kanedyn._output_files import new_file_mode, replacing
from kanedyn._progress import Progress
from kanedyn.cli import main
from kanedyn.modeling.vehicle import write_pulse_csv

SRC = Path(kd.__file__).resolve().parents[1]
PACKAGE = SRC / "kanedyn"


@pytest.fixture(scope="module")
def pendulum_run():
    d = kd.models.build("pendulum")
    eom = d.derive()
    model = d.numeric(eom, backend="numpy")
    return eom, model, kd.simulate(model, (0.0, 0.2), d.initial(model),
                                   t_eval=np.linspace(0.0, 0.2, 21))


class _Full(io.TextIOBase):
    """A text stream on a full disk: every write fails with ENOSPC."""

    def write(self, text):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def flush(self):
        pass


# ------------------------------------------------------------------ the helper
def test_a_file_is_made_privately_and_gets_the_mode_of_a_new_file(tmp_path):
    """While written the file is 0600 under another name; complete, it has the
    mode a new file gets under the umask (set here), and nothing else is left."""
    umask = os.umask(0o027)
    try:
        with replacing(tmp_path / "out.csv") as handle:
            handle.write("t\n0.0\n")
            assert stat.S_IMODE(os.fstat(handle.fileno()).st_mode) == 0o600
            assert not (tmp_path / "out.csv").exists()
            assert new_file_mode() == 0o640
    finally:
        os.umask(umask)
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]
    assert (tmp_path / "out.csv").read_text() == "t\n0.0\n"
    assert stat.S_IMODE((tmp_path / "out.csv").stat().st_mode) == 0o640


def test_a_link_at_the_target_is_replaced_not_followed(tmp_path):
    victim = tmp_path / "precious.conf"
    victim.write_text("kept")
    (tmp_path / "out.csv").symlink_to(victim)
    with replacing(tmp_path / "out.csv") as handle:
        handle.write("data")
    assert victim.read_text() == "kept"
    assert not (tmp_path / "out.csv").is_symlink()
    assert (tmp_path / "out.csv").read_text() == "data"


@pytest.mark.parametrize("stopped_by", [OSError(errno.EIO, "Input/output error"),
                                        KeyboardInterrupt()])
def test_a_write_that_fails_or_is_stopped_leaves_the_earlier_file(tmp_path, stopped_by):
    earlier = tmp_path / "out.csv"
    earlier.write_text("earlier")
    kind = kd.OutputFileError if isinstance(stopped_by, OSError) else KeyboardInterrupt
    with pytest.raises(kind) as raised, replacing(earlier) as handle:
        handle.write("half")
        raise stopped_by
    assert earlier.read_text() == "earlier"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]
    if kind is kd.OutputFileError:
        assert isinstance(raised.value, OSError) and raised.value.errno == errno.EIO
        assert raised.value.filename == str(earlier)
        assert str(raised.value) == f"cannot write {earlier}: Input/output error"


@pytest.mark.skipif(not Path("/dev/null").exists(), reason="no /dev/null")
def test_a_device_is_written_not_replaced():
    """``--c /dev/stdout``-like targets: a file that is not a regular one is written
    as ``open`` would (renaming over it, as root, would replace the device)."""
    with replacing("/dev/null") as handle:
        handle.write("nothing")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


_WRITERS = {"savefig", "write_text", "write_bytes", "to_csv", "to_parquet", "savez",
            "savez_compressed"}
# writes that need no helper: the compiler's cache (its own directories, checked by
# _trusted_files), a lock file, a figure into memory, and kanedyn's own writers
_ALLOWED = {("numerics/backends/_c_quick.py", "write_text"),
            ("numerics/backends/_c_quick.py", "open"),
            ("numerics/backends/_c_build.py", "write_text"),
            ("numerics/backends/_c_build.py", "open"),  # a checked object into a build folder
            ("_fork.py", "open"),  # a lock file, opened without following links
            ("_html.py", "savefig"),
            ("analysis/_seatbelt_studies.py", "to_csv"),  # LockMap.to_csv
            ("cli/_demo.py", "to_csv"),  # SimulationResult.to_csv
            ("cli/_inverse.py", "to_csv"),  # InverseStudy.to_csv
            ("cli/_optimize.py", "to_csv"),  # OptimalControlResult.to_csv (replacing)
            ("io/fmu/_export.py", "write_text")}  # C sources into its own temporary folder


def _writing_mode(node):
    modes = [a for a in node.args if isinstance(a, ast.Constant)]
    modes += [k.value for k in node.keywords if k.arg == "mode"]
    return any(isinstance(m, ast.Constant) and isinstance(m.value, str)
               and m.value[:1] in "wax" for m in modes)


def _raw_writes():
    """``(file, call)`` of the package's calls that write a file by its name, not
    through a handle that ``replacing`` gave."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text())
        handles = {item.optional_vars.id for node in ast.walk(tree)
                   if isinstance(node, ast.With) for item in node.items
                   if isinstance(item.context_expr, ast.Call)
                   and getattr(item.context_expr.func, "id", None) == "replacing"
                   and isinstance(item.optional_vars, ast.Name)}
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call):
                continue
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
            first = node.args[0] if node.args else None
            if isinstance(first, ast.Name) and first.id in handles:
                continue
            if name in _WRITERS or (name in ("open", "ZipFile") and _writing_mode(node)):
                found.append((str(path.relative_to(PACKAGE)), name, node.lineno))
    return found


def test_every_writer_of_a_users_file_goes_through_the_helper():
    """No module writes a file by name (``open(..., "w")``, ``savefig(path)``,
    ``write_text``, ``to_csv(path)``, ...) but through the helper, the compiler's
    cache aside: a writer added later that bypasses it fails here."""
    found = _raw_writes()  # one scan of the package for both checks (it parses every module)
    assert len(found) > len(_ALLOWED)  # the scan sees the allowed ones
    raw = [(f, name, line) for f, name, line in found if (f, name) not in _ALLOWED]
    assert not raw, raw


# ------------------------------------------------- the library on a full disk
def _writers():
    def sweep(res, path):
        model = res.model
        kd.sweep(model, {"m": [1.0, 2.0]}, res.initial_state, (0.0, 0.1), out=path,
                 scheduler="serial", progress=False, table_format="csv")

    return {
        "SimulationResult.to_csv": ("run.csv", lambda eom, res, p: res.to_csv(p)),
        "SimulationResult.to_npz": ("run.npz", lambda eom, res, p: res.to_npz(p)),
        "SimulationResult.plot": ("run.png", lambda eom, res, p: res.plot(path=p)),
        "SimulationResult.animate": ("run.html", lambda eom, res, p: res.animate(p)),
        "EquationsOfMotion.save": ("run.kdeom", lambda eom, res, p: eom.save(p)),
        "NumericModel.export_c": ("run.c", lambda eom, res, p: res.model.export_c(p)),
        "write_pulse_csv": ("pulse.csv", lambda eom, res, p: (
            write_pulse_csv(p, res.t, np.ones((res.t.size, 3))))),
        "kd.sweep(out=...)": ("sweep", lambda eom, res, p: sweep(res, p)),
    }


@pytest.mark.parametrize("writer", sorted(_writers()))
def test_library_writers_on_a_full_disk_leave_nothing(writer, pendulum_run, small_disk):
    """Each writer of a user's file: OutputFileError (an OSError) naming the file and
    "No space left on device"; the earlier file of that name as it was, and no
    other file left (they left files cut short: the CSV of ``kanedyn run``, the
    C source of ``derive --c``, a 0-byte sweep part)."""
    name, write = _writers()[writer]
    eom, _, res = pendulum_run
    disk = small_disk("256k")
    target = disk / name
    if target.suffix:
        target.write_text("earlier")
    small_disk.fill(disk)
    before = sorted(os.listdir(disk))
    try:
        with pytest.raises(kd.OutputFileError, match=f"cannot write {re.escape(str(disk))}/"
                                                     ".*: No space left on device"):
            write(eom, res, target)
    finally:
        import matplotlib.pyplot as plt
        plt.close("all")
    if target.suffix:
        assert target.read_text() == "earlier"
        assert sorted(os.listdir(disk)) == before
    else:  # the sweep's folder: made, nothing in it
        assert sorted(os.listdir(disk)) == sorted(before + [name]) and not os.listdir(target)


# ---------------------------------------------- the command line on a full disk
_COMMANDS = {
    "derive --c": ["derive", "pendulum", "--quiet", "--c", "{disk}/x.c"],
    "run --out --animate": ["run", "pendulum", "--t-end", "0.1", "--backend", "numpy",
                            "--quiet", "--animate", "--out", "{disk}/run"],
    "compare --plot": ["compare", "pendulum", "--t-end", "0.1", "--methods", "kane",
                       "--plot", "--quiet", "--out", "{disk}/cmp"],
    "sweep --csv": ["sweep", "pendulum", "--grid", "m=1:2:2", "--t-end", "0.1", "--csv",
                    "--scheduler", "serial", "--backend", "numpy", "--quiet",
                    "--out", "{disk}/sw"],
    "demo --out": ["demo", "--t-end", "0.1", "--quiet", "--out", "{disk}/demo"],
    "inverse --out": ["inverse", "3rrr", "--points", "5", "--backend", "numpy", "--quiet",
                      "--out", "{disk}/inv"],
}


@pytest.mark.parametrize("command", sorted(_COMMANDS))
def test_commands_on_a_full_disk_say_so_in_one_line(command, small_disk, capsys):
    """One line naming the file and the cause, exit code 2, no file left (derive --c
    left a truncated x.c with a traceback; demo, compare --plot and sweep --csv
    gave tracebacks, the sweep a 0-byte part)."""
    disk = small_disk("512k")
    small_disk.fill(disk)
    argv = [a.format(disk=disk) for a in _COMMANDS[command]]
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert re.fullmatch(f"kanedyn: error: cannot write {re.escape(str(disk))}/[^ ]+: "
                        "No space left on device\n", err), err
    left = [p for p in disk.rglob("*") if p.is_file() and p.name != "filler"]
    assert not left, left


# ------------------------------------------------------------ stdout and stderr
@pytest.mark.parametrize("argv", [["list"], ["derive", "pendulum", "--quiet"],
                                  ["run", "pendulum", "--t-end", "0.1", "--backend",
                                   "numpy", "--quiet", "--out", "{tmp}"]])
def test_a_full_stdout_is_one_line(argv, tmp_path, monkeypatch, capsys):
    """list, derive and run printed a traceback when stdout could not be written."""
    monkeypatch.setattr(sys, "stdout", _Full())
    assert main([a.format(tmp=tmp_path) for a in argv]) == 2
    assert capsys.readouterr().err == ("kanedyn: error: cannot write to standard output: "
                                       "No space left on device\n")


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
def test_stdout_on_dev_full_exits_2_without_more():
    """The program's exit: status 2 and the one line (not 120, Python's status when
    it cannot flush stdout at exit, with an "Exception ignored" message)."""
    with open("/dev/full", "w") as full:
        out = subprocess.run([sys.executable, "-m", "kanedyn.cli", "list"], stdout=full,
                             stderr=subprocess.PIPE, text=True, timeout=120,
                             env=dict(os.environ, PYTHONPATH=str(SRC)))
    assert out.returncode == 2, out.stderr
    assert out.stderr == ("kanedyn: error: cannot write to standard output: No space "
                          "left on device\n")


def test_a_run_whose_stderr_cannot_be_written_still_writes_its_results(
        tmp_path, monkeypatch, capsys):
    """Progress and messages on a full stderr are dropped; the run goes on (the
    first progress line raised, and the run stopped before writing anything)."""
    monkeypatch.setattr(sys, "stderr", _Full())
    code = main(["run", "pendulum", "--t-end", "0.1", "--backend", "numpy",
                 "--out", str(tmp_path)])
    assert code == 0
    assert "success: True" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pendulum.csv", "pendulum.png",
                                                         "summary.json"]


def test_progress_that_cannot_be_written_ends_quietly(monkeypatch):
    """The progress layer: a stream that fails (or none: stderr closed) ends the
    progress output, never the work; kd.simulate(progress=True) on a full stderr
    returns its result."""
    progress = Progress(stream=_Full(), interval=0.0)
    progress.stage("deriving")
    assert not progress.enabled
    progress = Progress(stream=_Full(), interval=0.0)
    progress.update("simulating", 0.5)
    progress.done()
    assert not progress.enabled
    monkeypatch.setattr(sys, "stderr", None)
    Progress().stage("stderr closed")
    monkeypatch.setattr(sys, "stderr", _Full())
    d = kd.models.build("pendulum")
    model = d.numeric(backend="numpy")
    res = kd.simulate(model, (0.0, 0.5), d.initial(model), progress=True)
    assert res.success


# --------------------------------------------------------------- links planted
@pytest.mark.skipif(not hasattr(os, "symlink"), reason="no symbolic links")
def test_run_never_writes_through_a_link_planted_in_its_output_folder(tmp_path):
    """A shared output folder (mode 0777): another user, seeing the process, plants
    links at the temporary names kanedyn used (``.<stem>.part<pid><suffix>``,
    plain ``open``): the run wrote its CSV into the link's target (a file of
    root's).  Now the temporary names are random and made exclusively."""
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    victim = tmp_path / "precious.conf"
    victim.write_text("root's configuration\n")
    proc = subprocess.Popen([sys.executable, "-m", "kanedyn.cli", "run", "pendulum",
                             "--t-end", "0.2", "--backend", "numpy", "--quiet",
                             "--out", str(shared)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONPATH=str(SRC)))
    for name in (f".pendulum.part{proc.pid}.csv", f".summary.part{proc.pid}.json",
                 f".pendulum.part{proc.pid}.png"):
        (shared / name).symlink_to(victim)
    err = proc.communicate(timeout=300)[1]
    assert proc.returncode == 0, err
    assert victim.read_text() == "root's configuration\n"
    for name in ("pendulum.csv", "summary.json", "pendulum.png"):
        assert not (shared / name).is_symlink() and (shared / name).stat().st_size > 0
