"""A cache no one else can plant code in, and a cache build on a full disk.

The attack: a cache directory another user can write to (or a file they own
in it) held a module whose constructor ran in the process that loaded it, as
root.  Here a second user (uid 65534) plants modules and objects whose
constructor writes a marker file; the victim (this user, root in CI) must never
run it.  The tests that need a second user (``chown``, a process of another
uid) or a file system of their own (a small tmpfs, for a full disk) run as root
only and are skipped otherwise, saying so.
"""

import grp
import hashlib
import json
import os
import pwd
import shutil
import stat
import struct
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pytest

from kanedyn import _fork
from kanedyn._trusted_files import (UntrustedFile, _private_group, open_trusted,
                                    trusted_directory, untrusted_entry)

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
def world(generic_runtime_object):
    """A folder in the system's temporary directory that another user can enter
    (``tmp_path`` cannot be), a module built in a cache of its own (the names a
    planter needs; the cache starts with the generic runtime's object, as a
    model built in it earlier would have left it), and the attacker's module
    and object, whose constructor writes ``marker``."""
    base = Path(tempfile.mkdtemp(prefix="kd-cache-safety-"))
    base.chmod(0o755)
    try:
        good = base / "good"
        generic_runtime_object(good)
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
    all can write, as /tmp): refused, naming its owner, and advising a cache
    of one's own (not to take the other user's folder over with chown)."""
    sticky = place / "sticky"
    sticky.mkdir()
    sticky.chmod(0o1777)
    theirs = sticky / "cache"
    _plant_as_other(world, theirs, make_dir=True)
    out = _victim(theirs)
    _refused_and_safe(world, out)
    assert (f"{theirs} is owned by another user (owner nobody (uid {OTHER}), mode drwxr-xr-x); "
            "set KANEDYN_CACHE_DIR to a directory of your own; nothing is loaded from it" in out)
    assert "chown" not in out


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
def test_an_entry_of_another_user_in_a_trusted_directory(world, place,
                                                        generic_runtime_object):
    """A module and manifest owned by another user in the victim's own 0700
    directory: not loaded, reported, removed and built again (root's own; the
    generic runtime's object linked from the cache, as a model built there
    earlier would have left it: the subject is the entry, not that compile)."""
    cache = place / "cache"
    generic_runtime_object(cache)
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
def test_an_entry_others_can_write(world, place, generic_runtime_object):
    """This user's own module, but writable by everyone: not loaded (the module
    built again in the cache, the generic runtime's object linked from it)."""
    cache = place / "cache"
    generic_runtime_object(cache)
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
def test_a_derivation_cache_entry_of_another_user_is_not_read(tmp_path,
                                                               generic_runtime_object):
    """A built-in model's derivation-cache entry given to another user: not
    read (the model is derived again), and reported.  The cache starts with the
    generic runtime's object (the pendulum's module links it: the subject is the
    derivation cache, not that compile)."""
    cache = tmp_path / "cache"
    generic_runtime_object(cache)
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
    cache, not as the cache; group-writable only for this user's private group;
    a symbolic link of this user is followed and the path returned resolved."""
    sticky = tmp_path / "sticky"
    sticky.mkdir()
    sticky.chmod(0o1777)
    assert trusted_directory(sticky / "a" / "b") == (sticky / "a" / "b", None)
    assert stat.S_IMODE((sticky / "a").stat().st_mode) == 0o700
    assert "can be written by every user" in trusted_directory(sticky)[1]
    loose = tmp_path / "loose"
    loose.mkdir()
    loose.chmod(0o777)
    assert f"{loose} can be written by every user" in trusted_directory(loose / "cache")[1]
    assert not (loose / "cache").exists()  # nothing is made under a folder not trusted
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "sticky" / "a")
    assert "is a symbolic link" in untrusted_entry(link)
    with pytest.raises(OSError, match="is a symbolic link"):
        open_trusted(link)
    assert trusted_directory(link / ".." / "a" / "b") == (sticky / "a" / "b", None)
    own = tmp_path / "own"
    own.mkdir()
    own.chmod(0o770)
    monkeypatch.setattr("kanedyn._trusted_files._private_group", lambda gid: True)
    assert trusted_directory(own) == (own, None)
    monkeypatch.setattr("kanedyn._trusted_files._private_group", lambda gid: False)
    assert "can be written by the users of group" in trusted_directory(own)[1]


def test_group_root_is_never_private():
    """Group 0 is never taken for a private group, though /etc/group lists no
    other member (processes of other users can hold it: ``docker --group-add
    0``, OpenShift), nor a group with other members (nogroup)."""
    _private_group.cache_clear()
    assert not _private_group(0)
    assert not _private_group(OTHER)


_ALICE = pwd.struct_passwd(("alice", "x", 5000, 5000, "", "/home/alice", "/bin/sh"))


@pytest.mark.parametrize("group, others, private", [
    (grp.struct_group(("alice", "x", 5000, [])), [], True),
    (grp.struct_group(("alice", "x", 5000, ["alice"])), [], True),
    (grp.struct_group(("alice", "x", 5000, ["bob"])), [], False),
    (grp.struct_group(("staff", "x", 5000, [])), [], False),
    (grp.struct_group(("alice", "x", 5000, [])),
     [pwd.struct_passwd(("bob", "x", 5001, 5000, "", "/home/bob", "/bin/sh"))], False),
], ids=["upg", "upg-listing-its-user", "another-member", "not-named-as-the-user",
        "another-users-primary-group"])
def test_private_group_of_a_directory_service_user(group, others, private, monkeypatch):
    """A user from LDAP or sssd (known to ``getpwuid``, not listed by
    ``getpwall``: sssd's default) whose primary group is named as the user and
    has no other member: a private group (their umask 002 makes folders
    group-writable, which must not cost a warning every run); any other member,
    another name, or another user's primary group: not."""
    monkeypatch.setattr(os, "geteuid", lambda: 5000)
    monkeypatch.setattr(pwd, "getpwuid", {5000: _ALICE}.__getitem__)
    monkeypatch.setattr(pwd, "getpwall", lambda: others)
    monkeypatch.setattr(grp, "getgrgid", lambda gid: group)
    _private_group.cache_clear()
    try:
        assert _private_group(5000) is private
    finally:
        _private_group.cache_clear()


# ------------------------------------------------------------------ ACLs
# POSIX ACLs are written as the kernel stores them (the extended attribute
# system.posix_acl_access or _default), so no setfacl is needed; where the file
# system has none, the tests are skipped.
_USER_OBJ, _USER, _GROUP_OBJ, _GROUP, _MASK, _OTHER = 0x01, 0x02, 0x04, 0x08, 0x10, 0x20


def _set_acl(path, users=(), mask=7, default=False, owner=7, group=0, other=0):
    """Give ``path`` an ACL: ``users`` (uid, permissions) entries besides the
    owner's, group and others'."""
    entries = [(_USER_OBJ, owner, 0xFFFFFFFF)] + [(_USER, perm, uid) for uid, perm in users] \
        + [(_GROUP_OBJ, group, 0xFFFFFFFF), (_MASK, mask, 0xFFFFFFFF),
           (_OTHER, other, 0xFFFFFFFF)]
    data = struct.pack("<I", 2) + b"".join(struct.pack("<HHI", *entry) for entry in entries)
    try:
        os.setxattr(path, f"system.posix_acl_{'default' if default else 'access'}", data)
    except (AttributeError, OSError) as exc:
        pytest.skip(f"no POSIX ACLs here ({exc})")


def test_an_acl_that_lets_another_user_write(tmp_path):
    """``setfacl -m u:nobody:rwx`` on the cache directory (the mode shows only
    the ACL's mask, drwxrwx---): refused, naming the user and the fix.  An ACL
    that lets them only read, or whose mask takes the writing away, is not."""
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    _set_acl(cache, users=[(OTHER, 7)])
    directory, problem = trusted_directory(cache)
    assert problem == (f"{cache} can be written by nobody (uid {OTHER}) through an access "
                       f"control list entry (owner {_me()}, mode drwxrwx---+); fix: "
                       f"`setfacl -x u:{OTHER} {cache}`")
    _set_acl(cache, users=[(OTHER, 5)])
    assert trusted_directory(cache) == (cache, None)
    _set_acl(cache, users=[(OTHER, 7)], mask=5)
    assert trusted_directory(cache) == (cache, None)
    module = cache / "module.so"
    module.write_bytes(b"module")
    module.chmod(0o600)
    _set_acl(module, users=[(OTHER, 6)], owner=6)
    with pytest.raises(UntrustedFile, match=r"module\.so can be written by nobody \(uid "
                                            r"65534\) through an access control list entry"):
        open_trusted(module)


def test_a_default_acl_on_the_cache_directory(tmp_path):
    """A default ACL that would let another user write what is created in the
    cache directory: refused.  A cache directory that kanedyn creates below a
    folder with such a default ACL does not keep what it would inherit, and is
    used."""
    parent = tmp_path / "parent"
    parent.mkdir(mode=0o755)
    _set_acl(parent, users=[(OTHER, 7)], default=True, group=5, other=5)
    directory, problem = trusted_directory(parent)
    assert problem == (f"{parent} lets nobody (uid {OTHER}) write what is created in it (a "
                       f"default access control list) (owner {_me()}, mode drwxr-xr-x+); fix: "
                       f"`setfacl -k {parent}`")
    assert trusted_directory(parent / "cache") == (parent / "cache", None)
    assert not [name for name in os.listxattr(parent / "cache") if "posix_acl" in name]
    assert stat.S_IMODE((parent / "cache").stat().st_mode) == 0o700


def _me():
    return f"{pwd.getpwuid(os.geteuid()).pw_name} (uid {os.geteuid()})"


@needs_root
@pytest.mark.slow
def test_a_module_planted_through_an_acl(world, place):
    """The reported case (P1-1): root's cache directory, shared with nobody by
    an ACL; nobody plants a module with the right checksum.  Not loaded."""
    cache = place / "cache"
    cache.mkdir(mode=0o700)
    _set_acl(cache, users=[(OTHER, 7)])
    _plant_as_other(world, cache, make_dir=False)
    out = _victim(cache)
    _refused_and_safe(world, out)
    assert (f"{cache} can be written by nobody (uid {OTHER}) through an access control list "
            "entry (owner root (uid 0), mode drwxrwx---+)") in out


@needs_root
@pytest.mark.slow
def test_a_module_planted_by_a_user_holding_group_root(world, place):
    """The reported case (P1-2): root's cache directory writable by group root
    (mode 0770, root:root), which /etc/group lists no member of; nobody runs
    with group 0 as a supplementary group and plants a module.  Not loaded."""
    cache = place / "cache"
    cache.mkdir()
    cache.chmod(0o770)
    os.chown(cache, 0, 0)
    manifest = world["so"].split(".")[0] + ".json"
    subprocess.run(["sh", "-c", f"cp {world['payload']} {cache / world['so']} && printf '%s' "
                    f"'{json.dumps({'sha256': world['sha256']})}' > {cache / manifest}"],
                   user=OTHER, group=OTHER, extra_groups=[0], check=True, timeout=60)
    out = _victim(cache)
    _refused_and_safe(world, out)
    assert (f"{cache} can be written by the users of group root (gid 0) (owner root (uid 0), "
            f"mode drwxrwx---); fix: `chmod g-w {cache}`") in out


# ------------------------------------------------------ the file checked is loaded
_SWAPPED = textwrap.dedent("""
    import os, sys
    from pathlib import Path
    from kanedyn.numerics.backends import _c_build
    cache, name, payload = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
    so_path, manifest = _c_build._entry(cache, name)
    checksum = _c_build._checksum

    def checksum_then_swap(handle):  # what another user's rename would do at that moment
        found = checksum(handle)
        os.replace(payload, so_path)
        return found
    _c_build._checksum = checksum_then_swap
    module = _c_build._try_cached(name, so_path, manifest, repair=False)
    print("loaded", module is not None and hasattr(module, "Model"), module.__file__)
""")


@pytest.mark.slow
def test_the_module_loaded_is_the_file_checked(world, place):
    """The module file is replaced by another (the payload) right after its
    owner, mode and checksum were checked, before the dynamic loader opens it
    (the window that P1-1's exploit raced for): what is loaded is the file
    checked, through its open descriptor, and the payload never runs."""
    if not os.path.isdir("/proc/self/fd"):
        pytest.skip("no /proc/self/fd: modules are loaded by path (the directory rules "
                    "protect them)")
    cache = place / "cache"
    shutil.copytree(world["good"], cache)
    swapped_in = place / "payload.so"
    shutil.copy(world["payload"], swapped_in)
    name = world["so"].split(".")[0]
    done = subprocess.run([sys.executable, "-c", _SWAPPED, str(cache), name, str(swapped_in)],
                          env=_environment(cache), capture_output=True, text=True, timeout=120)
    assert not world["marker"].exists(), "the planted code ran"
    assert f"loaded True {cache / world['so']}" in done.stdout, done.stdout + done.stderr
    assert (cache / world["so"]).read_bytes() == world["payload"].read_bytes()  # swapped


_MODULE_C = """
#include <Python.h>
static struct PyModuleDef def = {PyModuleDef_HEAD_INIT, "%(name)s", NULL, -1, NULL};
PyMODINIT_FUNC PyInit_%(name)s(void) {
    PyObject *m = PyModule_Create(&def);
    if (m) PyModule_AddStringConstant(m, "which", "%(name)s");
    return m;
}
"""


def test_modules_loaded_one_after_another_are_each_their_own(tmp_path):
    """Modules loaded through their descriptors one after another (each closed
    once loaded, so the next one gets the same number): the dynamic loader
    knows a library by the text of the path asked for, and the same
    ``/proc/self/fd/N`` would hand the first library out for the second; each
    module is its own."""
    import sysconfig

    from kanedyn.numerics.backends import _c_build
    cc = shutil.which("tcc") or shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    tag = f"{os.getpid()}_{tmp_path.name}".replace("-", "_")
    names = [f"_kd_fd_test_{k}_{tag}" for k in range(3)]
    for name in names:
        (tmp_path / f"{name}.c").write_text(_MODULE_C % {"name": name})
        subprocess.run([cc, "-shared", "-fPIC", "-w", f"-I{sysconfig.get_paths()['include']}",
                        str(tmp_path / f"{name}.c"), "-o", str(tmp_path / f"{name}.so")],
                       check=True, capture_output=True)
        (tmp_path / f"{name}.so").chmod(0o600)
    assert [_c_build._load(name, tmp_path / f"{name}.so").which for name in names] == names


# ------------------------------------------------------------ symbolic links
@needs_root
@pytest.mark.slow
def test_a_cache_directory_named_through_another_users_link(world, place):
    """The reported case (P1-3): KANEDYN_CACHE_DIR names a symbolic link that
    another user made in a sticky folder, pointing at a folder of root's:
    refused (as the kernel's fs.protected_symlinks would), and nothing in
    root's folder is written or removed."""
    sticky = place / "sticky"
    sticky.mkdir()
    sticky.chmod(0o1777)
    precious = place / "rootdata"
    precious.mkdir(mode=0o700)
    old = precious / "build-2019"
    old.mkdir()
    (old / "results.csv").write_text("years of work\n")
    os.utime(old, (time.time() - 7200, time.time() - 7200))
    link = sticky / "kdcache-root"
    subprocess.run(["ln", "-s", str(precious), str(link)], user=OTHER, group=OTHER,
                   extra_groups=[], check=True, timeout=60)
    out = _victim(link)
    assert "built -1.0" in out, out
    assert (f"the cache directory {link} ($KANEDYN_CACHE_DIR) could be changed by another "
            f"user, who could make this process run their code: {link} is a symbolic link "
            f"of another user (owner nobody (uid {OTHER}), mode lrwxrwxrwx); set "
            "KANEDYN_CACHE_DIR to a directory of your own") in out
    assert sorted(p.name for p in precious.iterdir()) == ["build-2019"]
    assert (old / "results.csv").read_text() == "years of work\n"


def test_stale_builds_removed_are_kanedyns_alone(tmp_path):
    """The cleanup of folders that killed builds left: only folders named as
    kanedyn names them (``tempfile.mkdtemp``'s build-XXXXXXXX) that hold only
    files kanedyn writes there; a user's build-2019 with results, or a build
    folder holding something else, is left as it is."""
    from kanedyn.numerics.backends import _c_build
    stale = Path(tempfile.mkdtemp(prefix="build-", dir=tmp_path))
    (stale / "unit0.c").write_text("int x;")
    (stale / "unit0.o").write_bytes(b"")
    users = tmp_path / "build-2019"
    users.mkdir()
    (users / "results.csv").write_text("years of work\n")
    mixed = Path(tempfile.mkdtemp(prefix="quick-", dir=tmp_path))
    (mixed / "notes.txt").write_text("mine\n")
    fresh = Path(tempfile.mkdtemp(prefix="build-", dir=tmp_path))
    for folder in (stale, users, mixed):
        os.utime(folder, (time.time() - 7200, time.time() - 7200))
    _c_build._remove_stale_builds(tmp_path, timeout=1)
    assert not stale.exists()
    assert (users / "results.csv").exists() and (mixed / "notes.txt").exists()
    assert fresh.exists()  # a build under way


# --------------------------------------------------- where the cache is, if anywhere
def _no_cache_settings(monkeypatch):
    for name in ("KANEDYN_CACHE_DIR", "XDG_CACHE_HOME", "HOME"):
        monkeypatch.delenv(name, raising=False)


@pytest.mark.parametrize("home", [None, "", "relative/home"], ids=["unset", "empty", "relative"])
def test_no_home_directory_gives_a_private_cache(home, monkeypatch):
    """HOME unset, empty or relative, and a user id with no entry in the user
    database (``docker run --user 12345``): no cache directory, a private one
    with a warning, never a traceback (P2-6)."""
    from kanedyn.numerics.backends import _c_build
    _no_cache_settings(monkeypatch)
    if home is not None:
        monkeypatch.setenv("HOME", home)

    def no_entry(uid):
        raise KeyError(f"getpwuid(): uid not found: {uid}")
    monkeypatch.setattr(pwd, "getpwuid", no_entry)
    monkeypatch.setattr(_c_build, "_PRIVATE", [])
    assert _c_build.cache_dir() is None
    with pytest.warns(RuntimeWarning, match=r"^there is no cache directory: KANEDYN_CACHE_DIR is "
                      r"not set, nor XDG_CACHE_HOME to an absolute path, and the home directory "
                      r"is unknown .*; compiled modules are built in \S+kanedyn-cache-\S+ for "
                      r"this process only"):
        private = _c_build.trusted_cache_dir()
    assert private == _c_build._PRIVATE[0]
    assert stat.S_IMODE(private.stat().st_mode) == 0o700


def test_where_the_cache_is(tmp_path, monkeypatch):
    """A relative XDG_CACHE_HOME is ignored (the XDG specification), as is an
    empty or relative HOME (the user database's home is used)."""
    from kanedyn.numerics.backends import _c_build
    _no_cache_settings(monkeypatch)
    database_home = pwd.getpwuid(os.getuid()).pw_dir
    monkeypatch.setenv("HOME", str(tmp_path))
    assert _c_build.cache_dir() == tmp_path / ".cache" / "kanedyn"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative")
    assert _c_build.cache_dir() == tmp_path / ".cache" / "kanedyn"
    assert _c_build._cache_origin() == "~/.cache/kanedyn"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert _c_build.cache_dir() == tmp_path / "xdg" / "kanedyn"
    monkeypatch.delenv("XDG_CACHE_HOME")
    for home in ("", "relative"):
        monkeypatch.setenv("HOME", home)
        assert _c_build.cache_dir() == Path(database_home) / ".cache" / "kanedyn"
    monkeypatch.setenv("KANEDYN_CACHE_DIR", "relative/cache")
    assert _c_build.cache_dir() == Path("relative/cache")


def test_the_private_directory_is_made_where_no_one_else_can_change_it(tmp_path, monkeypatch):
    """The private directory (where modules are built when the shared cache is
    not used) is not made in a temporary directory that other users can
    change (P3-12): there it is made in /tmp (sticky) instead, and the warning
    says why; it is 0700 and checked."""
    from kanedyn.numerics.backends import _c_build
    loose = tmp_path / "loose-tmp"
    loose.mkdir()
    loose.chmod(0o777)
    monkeypatch.setattr(tempfile, "tempdir", str(loose))
    monkeypatch.setattr(_c_build, "_PRIVATE", [])
    monkeypatch.setenv("KANEDYN_CACHE_DIR", str(loose / "cache"))
    with pytest.warns(RuntimeWarning) as caught:
        private = _c_build.trusted_cache_dir()
    assert loose not in private.parents
    assert stat.S_IMODE(private.stat().st_mode) == 0o700
    assert trusted_directory(private) == (private, None)
    (text,) = [str(w.message) for w in caught]
    assert text.endswith(f"; temporary directory passed over: {loose} can be written by every "
                         f"user (owner {_me()}, mode drwxrwxrwx); fix: `chmod o-w {loose}`")
    assert not list(loose.iterdir())


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
