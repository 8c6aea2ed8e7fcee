"""A cache no one else can plant code in, and a cache build on a full disk.

The attack: a cache directory another user can write to (or a file they own
in it) held a module whose constructor ran in the process that loaded it, as
root.  Here a second user (uid 65534) plants modules and objects whose
constructor writes a marker file; the victim (this user, root in CI) must never
run it.  The tests that need a second user (``chown``, a process of another
uid) or a file system of their own (a small tmpfs, for a full disk) run as root
only and are skipped otherwise, saying so.
"""

import hashlib
import json
import os
import shutil
import stat
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest

from kanedyn import _fork
from kanedyn._trusted_files import open_trusted, trusted_directory, untrusted_entry

OTHER = 65534  # nobody / nogroup
ROOT = os.geteuid() == 0 if hasattr(os, "geteuid") else False
needs_root = pytest.mark.skipif(
    not ROOT, reason="needs root: files of a second user (chown to uid 65534), a process "
                     "of that user, or a tmpfs of its own")

VICTIM = textwrap.dedent("""
    import sys, warnings
    import sympy as sm, sympy.physics.mechanics as me
    import kanedyn as kd
    q, u = me.dynamicsymbols("q u")
    c = sm.Symbol("c")
    N = me.ReferenceFrame("N"); O = me.Point("O"); O.set_vel(N, 0)
    P = O.locatenew("P", q * N.x); P.set_vel(N, u * N.x)
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u],
                  bodies=[me.Particle("p", P, 1)], loads=[(P, -c * q ** 3 * N.x)])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            model = eom.numeric(constants={c: 1.0}, backend="c")
            print("built", model.rhs(0.0, [1.0, 0.0])[1])
        except kd.KanedynError as exc:
            print("error", type(exc).__name__, exc)
    for w in caught:
        print("warning", w.category.__name__, w.message)
    print("stats", kd.numerics.COMPILE_STATS)
""")

PAYLOAD = """
#include <stdio.h>
__attribute__((constructor)) static void planted(void) {
    FILE *marker = fopen("%s", "w");
    if (marker) { fputs("the planted constructor ran", marker); fclose(marker); }
}
"""


def _environment(cache, **extra):
    """What the victim runs with: nothing inherited that changes the build."""
    env = {key: value for key, value in os.environ.items()
           if not key.startswith(("KANEDYN_", "XDG_CACHE")) and key not in ("CC", "TMPDIR")}
    return {**env, "KANEDYN_CACHE_DIR": str(cache), "KANEDYN_QUICK_CC": "",
            "PYTHONHASHSEED": "0", **extra}


def _victim(cache, **extra):
    """Run the model in a fresh process with the cache directory ``cache``."""
    done = subprocess.run([sys.executable, "-c", VICTIM], env=_environment(cache, **extra),
                          capture_output=True, text=True, timeout=300)
    return done.stdout + done.stderr


@pytest.fixture(scope="module")
def world():
    """A folder in the system's temporary directory that another user can enter
    (``tmp_path`` cannot be), a module built in a cache of its own (the names a
    planter needs), and the attacker's module and object, whose constructor
    writes ``marker``."""
    base = Path(tempfile.mkdtemp(prefix="kd-cache-safety-"))
    base.chmod(0o755)
    try:
        good = base / "good"
        out = _victim(good)
        assert "built -1.0" in out, out
        (so_path,) = good.glob("_kd_*.so")
        marker = base / "marker"
        source = base / "payload.c"
        source.write_text(PAYLOAD % marker)
        payload = base / "payload.so"
        cc = shutil.which("cc") or shutil.which("gcc")
        if cc is None:
            pytest.skip("no C compiler")
        subprocess.run([cc, "-shared", "-fPIC", str(source), "-o", str(payload)], check=True)
        subprocess.run([cc, "-c", "-fPIC", str(source), "-o", str(base / "payload.o")],
                       check=True)
        for path in (payload, base / "payload.o"):
            path.chmod(0o644)
        yield {"base": base, "good": good, "so": so_path.name, "marker": marker,
               "payload": payload, "sha256": hashlib.sha256(payload.read_bytes()).hexdigest()}
    finally:
        shutil.rmtree(base, ignore_errors=True)


@pytest.fixture()
def place(world, request):
    """A fresh folder under ``world["base"]`` (others may enter it); the marker removed."""
    folder = world["base"] / request.node.name.replace("[", "-").replace("]", "")
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir()
    folder.chmod(0o755)
    world["marker"].unlink(missing_ok=True)
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def _plant_as_other(world, cache, make_dir):
    """The second user puts the payload module, with a manifest of the right
    checksum, into ``cache`` (creating it when ``make_dir``)."""
    so_name = world["so"]
    manifest = so_name.split(".")[0] + ".json"
    script = (f"{'mkdir -p ' + str(cache) + ' && ' if make_dir else ''}"
              f"cp {world['payload']} {cache / so_name} && "
              f"printf '%s' '{json.dumps({'sha256': world['sha256']})}' > {cache / manifest}")
    subprocess.run(["sh", "-c", script], user=OTHER, group=OTHER, extra_groups=[], check=True,
                   timeout=60)
    assert (cache / so_name).stat().st_uid == OTHER


def _refused_and_safe(world, out):
    assert not world["marker"].exists(), "the planted code ran"
    assert "built -1.0" in out, out


@needs_root
@pytest.mark.slow
def test_a_module_planted_by_another_user_in_a_directory_all_can_write(world, place):
    """The reported case: a cache directory of the victim that everyone can
    write (as for a team's shared cache); another user plants a module there."""
    shared = place / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    _plant_as_other(world, shared, make_dir=False)
    out = _victim(shared)
    _refused_and_safe(world, out)
    assert (f"the cache directory {shared} ($KANEDYN_CACHE_DIR) could be changed by another "
            f"user, who could make this process run their code: {shared} can be written by "
            "every user (owner root (uid 0), mode drwxrwxrwx); fix: `chmod o-w") in out
    assert "nothing is loaded from it; compiled modules are built in" in out


@needs_root
@pytest.mark.slow
def test_a_cache_directory_of_another_user(world, place):
    """The cache directory names a folder another user made (in a sticky folder
    all can write, as /tmp): refused, naming its owner and the fix."""
    sticky = place / "sticky"
    sticky.mkdir()
    sticky.chmod(0o1777)
    theirs = sticky / "cache"
    _plant_as_other(world, theirs, make_dir=True)
    out = _victim(theirs)
    _refused_and_safe(world, out)
    assert (f"{theirs} is owned by another user (owner nobody (uid {OTHER}), mode drwxr-xr-x); "
            f"fix: `chown root {theirs}`, or set KANEDYN_CACHE_DIR to a directory of your own"
            in out)


@needs_root
@pytest.mark.slow
def test_a_directory_above_the_cache_that_another_user_owns(world, place):
    """The victim's own cache directory, inside a folder of the other user (who
    could rename it and put one of theirs in its place): refused, naming that
    folder."""
    home = place / "home"
    home.mkdir()
    cache = home / "cache"
    cache.mkdir(mode=0o700)
    shutil.copy(world["payload"], cache / world["so"])
    (cache / (world["so"].split(".")[0] + ".json")).write_text(
        json.dumps({"sha256": world["sha256"]}))
    os.chown(home, OTHER, OTHER)
    out = _victim(cache)
    _refused_and_safe(world, out)
    assert f"{home} is owned by another user (owner nobody (uid {OTHER})" in out


@needs_root
@pytest.mark.slow
def test_an_entry_of_another_user_in_a_trusted_directory(world, place):
    """A module and manifest owned by another user in the victim's own 0700
    directory: not loaded, reported, removed and built again (root's own)."""
    cache = place / "cache"
    cache.mkdir(mode=0o700)
    so_path = cache / world["so"]
    manifest = cache / (world["so"].split(".")[0] + ".json")
    shutil.copy(world["payload"], so_path)
    manifest.write_text(json.dumps({"sha256": world["sha256"]}))
    for path in (so_path, manifest):
        os.chown(path, OTHER, OTHER)
    out = _victim(cache)
    _refused_and_safe(world, out)
    assert "could be changed by another user" not in out
    assert (f"is owned by another user (owner nobody (uid {OTHER}), mode -rw-r--r--): not "
            "loaded (the cache loads only files of this user or root that no one else can "
            "write); it is removed and built again") in out
    assert so_path.stat().st_uid == 0 and manifest.stat().st_uid == 0
    assert stat.S_IMODE(so_path.stat().st_mode) == 0o600


@pytest.mark.slow
def test_an_entry_others_can_write(world, place):
    """This user's own module, but writable by everyone: not loaded."""
    cache = place / "cache"
    cache.mkdir(mode=0o700)
    so_path = cache / world["so"]
    shutil.copy(world["payload"], so_path)
    (cache / (world["so"].split(".")[0] + ".json")).write_text(
        json.dumps({"sha256": world["sha256"]}))
    so_path.chmod(0o666)
    out = _victim(cache)
    _refused_and_safe(world, out)
    assert f"{so_path} can be written by every user" in out


@needs_root
@pytest.mark.slow
def test_objects_planted_by_another_user_are_not_linked(world, place):
    """Cached objects of the module's own units, each with the payload linked
    in (``ld -r``: the module would link and load) and given to another user:
    the units are compiled instead."""
    cache = place / "cache"
    shutil.copytree(world["good"], cache)
    for path in cache.glob("_kd_*"):
        path.unlink()
    objects = sorted((cache / "objects").glob("*.o"))
    assert objects
    for path in objects:
        combined = path.with_suffix(".planted")
        subprocess.run(["ld", "-r", str(path), str(world["base"] / "payload.o"), "-o",
                        str(combined)], check=True)
        combined.replace(path)
        os.chown(path, OTHER, OTHER)
    out = _victim(cache)
    _refused_and_safe(world, out)
    assert f"is owned by another user (owner nobody (uid {OTHER})" in out
    assert "'reused': 0" in out


@pytest.mark.slow
def test_created_with_private_modes(world, place):
    """Directories 0700 and files 0600, whatever the umask (here 002, which
    made everything group-writable)."""
    cache = place / "deep" / "cache"
    script = f"import os; os.umask(0o002); exec(compile({VICTIM!r}, 'victim', 'exec'))"
    done = subprocess.run([sys.executable, "-c", script], env=_environment(cache),
                          capture_output=True, text=True, timeout=300)
    assert "built -1.0" in done.stdout, done.stdout + done.stderr
    folders = [place / "deep", cache, cache / "objects"]
    files = [path for path in cache.rglob("*") if path.is_file()]
    assert any(path.suffix == ".lock" for path in files) and len(files) >= 4
    for path in folders:
        assert stat.S_IMODE(path.stat().st_mode) == 0o700, path
    for path in files:
        assert stat.S_IMODE(path.stat().st_mode) == 0o600, path


def test_lock_file_does_not_follow_a_symbolic_link(tmp_path):
    target = tmp_path / "elsewhere"
    (tmp_path / "x.lock").symlink_to(target)
    with pytest.raises(OSError), _fork.FileLock(tmp_path / "x.lock"):
        pass
    assert not target.exists()
    with _fork.FileLock(tmp_path / "y.lock"):
        pass
    assert stat.S_IMODE((tmp_path / "y.lock").stat().st_mode) == 0o600


@needs_root
@pytest.mark.slow
def test_a_derivation_cache_entry_of_another_user_is_not_read(tmp_path):
    """A built-in model's derivation-cache entry given to another user: not
    read (the model is derived again), and reported."""
    cache = tmp_path / "cache"
    script = textwrap.dedent("""
        import warnings
        warnings.simplefilter("always")
        import kanedyn as kd
        from kanedyn.models._base import DERIVE_STATS
        d = kd.models.build("pendulum", lazy=True)
        m = d.numeric(backend="c")
        print("rhs", m.rhs(0.0, d.initial(m))[1], "derivations", DERIVE_STATS["derivations"])
    """)

    def run():
        done = subprocess.run([sys.executable, "-c", script], env=_environment(cache),
                              capture_output=True, text=True, timeout=300)
        assert "Traceback" not in done.stderr, done.stderr
        return done.stdout + done.stderr

    assert "derivations 1" in run()
    assert "derivations 0" in run()
    (entry,) = (cache / "derived").glob("*.kdnum")
    os.chown(entry, OTHER, OTHER)
    out = run()
    assert "derivations 1" in out
    assert (f"derivation cache entry {entry} cannot be used ({entry} is owned by another "
            f"user (owner nobody (uid {OTHER}), mode -rw-------): not read") in out


# ------------------------------------------------------------------ the rules
def test_rules_of_trust(tmp_path, monkeypatch):
    """The checks themselves: a sticky folder all can write is fine above the
    cache, not as the cache; group-writable only for a group of this user alone."""
    sticky = tmp_path / "sticky"
    sticky.mkdir()
    sticky.chmod(0o1777)
    assert trusted_directory(sticky / "a" / "b") is None
    assert stat.S_IMODE((sticky / "a").stat().st_mode) == 0o700
    assert "can be written by every user" in trusted_directory(sticky)
    loose = tmp_path / "loose"
    loose.mkdir()
    loose.chmod(0o777)
    assert f"{loose} can be written by every user" in trusted_directory(loose / "cache")
    assert not (loose / "cache").exists()  # nothing is made under a folder not trusted
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "sticky" / "a")
    assert "is a symbolic link" in untrusted_entry(link)
    with pytest.raises(OSError, match="is a symbolic link"):
        open_trusted(link)
    own = tmp_path / "own"
    own.mkdir()
    own.chmod(0o770)
    monkeypatch.setattr("kanedyn._trusted_files._private_group", lambda gid: True)
    assert trusted_directory(own) is None
    monkeypatch.setattr("kanedyn._trusted_files._private_group", lambda gid: False)
    assert "can be written by the users of group" in trusted_directory(own)


@needs_root
def test_group_of_this_user_alone():
    """Root's group has root alone as a member; nogroup has others (nobody)."""
    from kanedyn._trusted_files import _private_group
    assert _private_group(0)
    assert not _private_group(OTHER)


# ------------------------------------------------------------------ full disk
@needs_root
@pytest.mark.slow
@pytest.mark.parametrize("quick", ["", "tcc"])
def test_full_disk_builds_in_a_private_directory(quick, small_disk):
    """The cache directory exists, its disk is full: the module is built in a
    private directory, with a warning naming the cache and what failed (with
    TinyCC, its quick build fails first, as reported)."""
    if quick and shutil.which("tcc") is None:
        pytest.skip("TinyCC is not installed")
    disk = small_disk()
    cache = disk / "cache"
    cache.mkdir(mode=0o700)
    small_disk.fill(disk)
    out = _victim(cache, KANEDYN_QUICK_CC=quick)
    assert "built -1.0" in out, out
    assert f"the cache directory {cache} could not be written (" in out
    assert "No space left on device); compiled modules are built in" in out
    assert "free some space there to keep them" in out


@needs_root
@pytest.mark.slow
def test_full_disk_under_the_compiler(tmp_path, small_disk):
    """The disk fills while the linker writes the module (a compiler command
    that fills it before linking): the linker's failure is recognised as a full
    disk and the module built in a private directory."""
    disk = small_disk()
    cache = disk / "cache"
    cache.mkdir(mode=0o700)
    filling_cc = tmp_path / "filling-cc"
    filling_cc.write_text(
        "#!/bin/sh\n"
        f'case "$*" in *-shared*) cat /dev/zero > {disk}/filler 2>/dev/null;; esac\n'
        f'exec {shutil.which("cc") or "gcc"} "$@"\n')
    filling_cc.chmod(0o755)
    out = _victim(cache, CC=str(filling_cc))
    assert "built -1.0" in out, out
    assert f"the cache directory {cache} could not be written (" in out
    assert "final link failed: No space left on device); compiled modules are built in" in out


@needs_root
@pytest.mark.slow
def test_full_disk_everywhere_is_a_clear_error(small_disk):
    """The cache's disk is full and so is the compiler's temporary directory
    ($TMPDIR; Python's then falls back to /tmp): a CompilerError naming the
    private directory and the file that could not be written, not an OSError
    traceback."""
    disk = small_disk()
    cache = disk / "cache"
    cache.mkdir(mode=0o700)
    small_disk.fill(disk)
    out = _victim(cache, TMPDIR=str(disk))
    assert f"the cache directory {cache} could not be written" in out
    assert "error CompilerError a compiled module could not be built in " in out
    assert f"error writing to {disk}/" in out and ": No space left on device); free some " \
        "space there or set KANEDYN_CACHE_DIR (TMPDIR for a private directory)" in out
