"""``export_fmu``: a numerical model as an FMI 2.0 or 3.0 FMU (model exchange and
co-simulation), compiled from the standalone C export; no Python needed to run it.

The archive holds ``modelDescription.xml``, ``sources/model.c`` (the
standalone export, :meth:`NumericModel.c_source`), ``sources/fmi2.c`` or
``sources/fmi3.c`` (the FMI interface; FMI 3.0 adds
``sources/buildDescription.xml``) and
``binaries/<platform>/<identifier>.<so|dylib>`` built from both with the C
compiler the C backend uses.
"""

from __future__ import annotations

import hashlib
import platform
import re
import subprocess
import tempfile
import uuid
import zipfile
from pathlib import Path

import numpy as np

from ..._errors import ModelError, OptionError
from ..._output_files import replacing
from ...numerics.backends import CompilerError, compiler_command, missing_compiler_text
from ...numerics.backends import _c_build
from ._description import build_description, model_description
from ._variables import fmu_variables
from ._wrapper import WRAPPER_FILES, wrapper_source

__all__ = ["export_fmu", "FMU_SOURCES", "FMI_VERSIONS"]

#: the FMI major versions written
FMI_VERSIONS = (2, 3)
#: the C files in ``sources/``, per FMI version (compile both into one shared library)
FMU_SOURCES = {version: ("model.c", WRAPPER_FILES[version]) for version in FMI_VERSIONS}
#: the binaries' file suffix and FMI 2.0's folder, per operating system
_PLATFORMS = {"Linux": (".so", "linux64"), "Darwin": (".dylib", "darwin64")}
#: FMI 3.0's names of the processor architectures (its folders: ``x86_64-linux``, ...)
_ARCHITECTURES = {"x86_64": "x86_64", "amd64": "x86_64", "aarch64": "aarch64",
                  "arm64": "aarch64"}


def _platform(fmi_version):
    """(the binaries' folder, file suffix) for this machine."""
    system = platform.system()
    machine = platform.machine().lower()
    if (system not in _PLATFORMS or platform.architecture()[0] != "64bit"
            or (fmi_version == 3 and machine not in _ARCHITECTURES)):
        raise OptionError(f"FMU export builds binaries for 64-bit Linux and macOS only "
                          f"(this is {system}, {platform.architecture()[0]}, {machine})")
    suffix, folder = _PLATFORMS[system]
    if fmi_version == 3:
        folder = f"{_ARCHITECTURES[machine]}-{system.lower()}"
    return folder, suffix


def _check_version(fmi_version):
    if isinstance(fmi_version, bool) or fmi_version not in FMI_VERSIONS:
        raise OptionError(f"fmi_version must be 2 or 3 (FMI 2.0 or 3.0), got "
                          f"{fmi_version!r}")
    return int(fmi_version)


def _identifier(name):
    """A C identifier from a model's name (``four-bar`` -> ``four_bar``)."""
    text = re.sub(r"\W", "_", name or "kanedyn_model", flags=re.ASCII)
    return text if text[:1].isalpha() else "m_" + text


def _check_path(path):
    path = Path(path)
    if path.suffix.lower() != ".fmu":
        raise OptionError(f"the FMU file name must end in .fmu, got {str(path)!r}")
    return path


def _check_model(model):
    """What the contact loop of the FMU (co-simulation) does not port is refused."""
    if not model.contacts:
        return
    names = ", ".join(c["name"] for c in model.contacts)
    for c in model.contacts:
        if c["kind"] != "unilateral":
            raise ModelError(f"cannot export an FMU of contact {c['name']}: it is "
                             f"{c['kind']}, and the FMU's contact loop handles unilateral "
                             "contacts only (kd.simulate handles it)")
    if model.n_u_dep or model.n_q_dep:
        raise ModelError(f"cannot export an FMU of a model with contacts ({names}) and "
                         "constraints (dependent coordinates or speeds): the FMU's contact "
                         "loop handles unconstrained models only (kd.simulate handles it)")
    if model.input_names:
        raise ModelError(f"cannot export an FMU of a model with contacts ({names}) and "
                         f"specified inputs ({', '.join(model.input_names)}): the FMU's "
                         "contact loop handles models without inputs only")


def _settings(rtol, atol, projection_tol):
    values = {"kanedyn.rtol": rtol, "kanedyn.atol": atol,
              "kanedyn.projection_tol": (max(100 * atol, 1e-10) if projection_tol is None
                                         else projection_tol)}
    for (name, value), option in zip(values.items(), ("rtol", "atol", "projection_tol")):
        if not (isinstance(value, (int, float)) and np.isfinite(value)
                and (value >= 0 if option == "projection_tol" else value > 0)):
            raise OptionError(f"{option} must be a finite number "
                              f"{'>= 0' if option == 'projection_tol' else '> 0'}, "
                              f"got {value!r}")
    return values


def _check_nominals(model, nominals):
    """``{state name: float}`` from the user's ``nominals``, checked."""
    checked = {}
    for name, value in (nominals or {}).items():
        name = str(name)
        if name not in model.state_names:
            raise OptionError(f"nominals names {name!r}, which is not a state of the model; "
                              f"its states: {', '.join(model.state_names)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not (np.isfinite(value) and value > 0):
            raise OptionError(f"the nominal value of {name} must be a finite number > 0, "
                              f"got {value!r}")
        checked[name] = float(value)
    return checked


def _check_names(layout):
    seen = {}
    for v in layout.variables:
        if v.name in seen:
            raise ModelError(f"cannot export an FMU: two variables are named {v.name!r} "
                             f"(a {seen[v.name]} and a {v.causality}); rename one")
        seen[v.name] = v.causality


#: the compiler's options for each C file of an FMU
_FMU_FLAGS = ["-fPIC", "-O2", "-std=c99", "-fvisibility=hidden"]


def _compile(sources, folder, library):
    """Build ``library`` from the C files ``sources`` in ``folder``: each compiled
    to an object with :data:`_FMU_FLAGS` (as one ``cc -shared`` command of all
    of them compiles each), then linked.  An object is kept in the object cache
    of the C backend's cache directory under the hash of its text and the
    command, and a file met again is linked from there (``model.c`` is the same
    for FMI 2.0 and 3.0, for other start values, tolerances and nominals: 2.5 s
    of gcc for a contact model), with the cache's checks (this user's or
    root's, writable by no one else; else compiled)."""
    cc = compiler_command()
    if cc is None:
        raise CompilerError(f"cannot build the FMU's binary: {missing_compiler_text()}")
    directory = _object_cache()
    objects = []
    for name in sources:
        source = folder / name
        made = source.with_suffix(".o")
        cached = None if directory is None else directory / "objects" / (
            "fmu-" + _c_build._build_key(source.read_text(), cc + _FMU_FLAGS) + ".o")
        if cached is None or not _c_build._reuse(cached, made):
            _run_compiler([*cc, *_FMU_FLAGS, "-c", str(source), "-o", str(made)])
            if cached is not None:
                _c_build._keep_objects([(made, cached)])
        objects.append(made)
    _run_compiler([*cc, "-shared", *map(str, objects), "-o", str(library), "-lm"])


def _object_cache():
    """The C backend's cache directory where objects may be read from and kept
    (``None``: none, or not one this user alone can change)."""
    directory, unusable, unwritable = _c_build._shared_cache()
    return directory if unusable is None and unwritable is None else None


def _run_compiler(command):
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise CompilerError(f"the C compiler failed to build the FMU's binary "
                            f"({' '.join(command)}):\n{done.stderr[-4000:]}")


def export_fmu(model, path, y0, t_end=None, rtol=1e-10, atol=1e-10, projection_tol=None,
               constant_units=None, identifier=None, title=None, fmi_version=2,
               nominals=None):
    """Write ``model`` as an FMI 2.0 or 3.0 FMU for model exchange and co-simulation.

    Parameters
    ----------
    model : NumericModel
        With contacts the co-simulation step runs the contact loop of
        ``kd.simulate`` in C (modes, events, single-contact impacts) and model
        exchange has two event indicators per contact, the impacts and mode changes
        in the event update (see ``docs/fmu.md`` for what it refuses).
    path : str or Path
        The file to write; its name must end in ``.fmu``.
    y0 : array_like or dict
        Initial state (as for :func:`kanedyn.simulate`): the start values of the
        states, made consistent with the constraints first.
    t_end : float, optional
        Stop time of the FMU's default experiment [s].
    rtol, atol : float
        Tolerances of the co-simulation step's integration (FMI parameters
        ``kanedyn.rtol``, ``kanedyn.atol``).
    projection_tol : float, optional
        Largest constraint residual before the state is projected
        (``kanedyn.projection_tol``); default ``max(100 atol, 1e-10)``, as
        :func:`kanedyn.simulate`.
    constant_units : dict, optional
        ``{constant name: unit}`` for constants whose unit is declared
        (``ModelDefinition.constant_units``).
    identifier : str, optional
        The FMU's ``modelIdentifier`` (a C identifier); default from the model's
        name.
    title : str, optional
        The model's description in the FMU.
    fmi_version : {2, 3}
        The FMI standard written: 2 (FMI 2.0, the default) or 3 (FMI 3.0: ``Float64``
        variables, the independent variable ``time``, ``buildDescription.xml``;
        co-simulation holds the inputs over a step). Both versions share the
        model's C and the core of the interface, and give the same results.
    nominals : dict, optional
        ``{state name: typical magnitude}`` (in the state's SI unit): the states'
        ``nominal`` values, which ``fmi2GetNominalsOfContinuousStates``
        (``fmi3…``) returns and importers scale their absolute tolerance by
        (FMPy's CVODE: ``atol = rtol * nominal``). A state not named has FMI's
        default, 1. Small states (elastic coordinates of millimetres) need them
        for an accurate model-exchange run.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OptionError
        A file name not ending in ``.fmu``, a bad tolerance, identifier,
        ``fmi_version`` or nominal value.
    ModelError
        A model whose equations are not available, or with contacts the FMU does not
        handle (bilateral ones; with constraints or specified inputs).
    CompilerError
        No C compiler, or the build failed.
    """
    path = _check_path(path)
    fmi_version = _check_version(fmi_version)
    _check_model(model)
    folder_name, suffix = _platform(fmi_version)
    sources = FMU_SOURCES[fmi_version]
    identifier = identifier or _identifier(model.name)
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", identifier, flags=re.ASCII):
        raise OptionError(f"identifier must be a C identifier, got {identifier!r}")
    settings = _settings(rtol, atol, projection_tol)
    y_start = model.state(y0)
    r_start = model.input_values(0.0, y_start)
    # units of constants the equations do not use (dropped from the model) have no
    # variable to go to; any other name is a mistake
    dropped = set(model._data.get("unused_constants", ()))
    units = {str(k): v for k, v in (constant_units or {}).items() if str(k) not in dropped}
    unknown = sorted(set(units) - set(model.constants))
    if unknown:
        raise OptionError(f"constant_units names {', '.join(unknown)}, which are not "
                          f"constants of the model; its constants: "
                          f"{', '.join(model.constants)}")
    layout = fmu_variables(model, y_start, r_start, settings, units,
                           _check_nominals(model, nominals),
                           indicators=fmi_version == 3 and bool(model.contacts))
    _check_names(layout)
    title = title or model.title or model.name or "a kanedyn model"
    model_c = model._c_text(title=title, contacts=True) if model.contacts \
        else model.c_source(title=title)
    digest = hashlib.sha256("\n".join([model_c, repr(layout), str(fmi_version)])
                            .encode()).digest()
    guid = "{" + str(uuid.UUID(bytes=digest[:16], version=4)) + "}"
    wrapper_c = wrapper_source(layout, identifier, guid, title,
                               model.n_q_dep + model.n_u_dep, list(settings.values()),
                               fmi_version, len(model.contacts))
    xml = model_description(layout, identifier, guid, model.name or identifier, title,
                            sources, stop_time=t_end, tolerance=rtol,
                            fmi_version=fmi_version,
                            event_indicators=2 * len(model.contacts))
    with tempfile.TemporaryDirectory(prefix="kanedyn-fmu-") as temporary:
        folder = Path(temporary)
        (folder / "model.c").write_text(model_c)
        (folder / sources[1]).write_text(wrapper_c)
        library = folder / f"{identifier}{suffix}"
        _compile(sources, folder, library)
        with replacing(path, "wb") as handle:
            with zipfile.ZipFile(handle, "w", zipfile.ZIP_DEFLATED) as archive:
                archive.writestr("modelDescription.xml", xml)
                for name in sources:
                    archive.write(folder / name, f"sources/{name}")
                if fmi_version == 3:
                    archive.writestr("sources/buildDescription.xml",
                                     build_description(identifier, sources))
                archive.write(library, f"binaries/{folder_name}/{identifier}{suffix}")
    return path
