"""Built-in models, usable from Python and from the CLI (``kanedyn list``).

>>> import kanedyn as kd
>>> definition = kd.models.build("pendulum")
>>> eom = definition.derive()
>>> model = definition.numeric(eom)
"""

from __future__ import annotations

from .._lazy import NAMESPACES as _NAMESPACES
from .._lazy import lazy_attributes as _lazy_attributes
from .._errors import ModelError
from . import _oc3_options

#: public name -> the module (in this package) that defines it; imported on first use
_LAZY = {
    'ModelDefinition': '._base',
    'PendingDefinition': '._pending',
    'eigenvalues_vs_speed': '._bicycle_analysis',
    'stability_speeds': '._bicycle_analysis',
    'upright_state': '._bicycle_analysis',
    'chain3d': '._classic',
    'chaplygin_sleigh': '._classic',
    'four_bar': '._classic',
    'n_link_pendulum_on_cart': '._classic',
    'pendulum': '._classic',
    'block_wedge': '._constraint_models',
    'knife_edge': '._constraint_models',
    'pin_slot': '._constraint_models',
    'rod_bead': '._constraint_models',
    'rolling_disk_contact': '._constraint_models',
    'bead_in_tube': '._contact_models',
    'block_on_incline': '._contact_models',
    'bouncing_ball': '._contact_models',
    'falling_rod': '._contact_models',
    'ladder': '._contact_models',
    'slug_ellipsoid': '._contact_models',
    'sphere_slug': '._contact_models',
    'flexible_robot': '._flexible_models',
    'spin_up_beam': '._flexible_models',
    'rotating_cantilever': '._rotor_models',
    'lag_rotor': '._rotor_models',
    'andrews_squeezer': '._andrews',
    'ANDREWS_INITIAL': '._andrews',
    'n_four_bar': '._iftomm',
    'n_four_bar_exact': '._iftomm',
    'n_four_bar_singular_times': '._iftomm',
    'nonholonomic_particle': '._nonholonomic',
    'sphere_on_turntable': '._nonholonomic',
    'OUT_PARALLEL_GEOMETRY': '._out_parallel',
    'OUT_PARALLEL_INERTIA': '._out_parallel',
    'out_parallel_6dof': '._out_parallel',
    'out_parallel_anchors': '._out_parallel',
    'out_parallel_ik': '._out_parallel',
    'OutParallelMachine': '._out_parallel_machine',
    'read_out_parallel_machine': '._out_parallel_machine',
    'MACHINE_KEYS': '._out_parallel_machine',
    'PLANAR_3RRR_GEOMETRY': '._parallel',
    'STEWART_GEOMETRY': '._parallel',
    'newton_ik': '._parallel',
    'planar_3rrr': '._parallel',
    'planar_3rrr_ik': '._parallel',
    'quintic_pose': '._parallel',
    'sinusoid_pose': '._parallel',
    'stewart_anchors': '._parallel',
    'stewart_leg_lengths': '._parallel',
    'stewart_platform': '._parallel',
    'MEIJAARD_2007': '._rolling',
    'rolling_disk': '._rolling',
    'whipple_bicycle': '._rolling',
    'shuttle_arm': '._shuttle_arm',
    'SRMS_START_DEG': '._shuttle_arm',
    'SRMS_END_DEG': '._shuttle_arm',
    'snake': '._snake',
    'JointInfo': '._urdf',
    'URDFDefinition': '._urdf',
    'URDFError': '._urdf',
    'Visual': '._urdf',
    'from_urdf': '._urdf',
    'from_mjcf': '.mjcf',
    'MJCFDefinition': '.mjcf',
    'MJCFError': '.mjcf',
    'oc3_spar': '._oc3_spar',
    'oc3_settle': '._oc3_spar',
    'oc3_static_offsets': '._oc3_spar',
    'oc3_tower': '._oc3_tower',
    'oc3_tower_member': '._oc3_tower',
    'oc3_rna_node_mass': '._oc3_tower',
    'OC3_SPAR_OPTIONS': '._oc3_options',
    'oc3_operating_point': '._oc3_rotor',
    'OperatingPoint': '._oc3_rotor',
    'seatbelt_sensor': '._seatbelt',
    'seatbelt_motion': '._seatbelt',
    'seatbelt_report': '._seatbelt',
    'seatbelt_tilt': '._seatbelt',
    'lock_events': '._seatbelt',
    'SeatbeltReport': '._seatbelt',
    'SEATBELT_DEFAULTS': '._seatbelt',
    'oc3_tower_rna_basis': '._oc3_tower',
}


__all__ = ["ModelDefinition", "PendingDefinition", "REGISTRY", "OPTION_UNITS", "build",
           "available", "similar_models", "unknown_model_text", "options_adding", "pendulum",
           "n_link_pendulum_on_cart", "chain3d", "chaplygin_sleigh", "four_bar",
           "rolling_disk", "whipple_bicycle", "MEIJAARD_2007", "sphere_slug",
           "slug_ellipsoid", "block_on_incline", "bead_in_tube", "bouncing_ball", "ladder",
           "falling_rod", "rotating_cantilever", "lag_rotor",
           "nonholonomic_particle", "sphere_on_turntable", "rod_bead", "pin_slot", "knife_edge",
           "rolling_disk_contact", "block_wedge", "snake", "shuttle_arm", "SRMS_START_DEG",
           "SRMS_END_DEG", "n_four_bar",
           "n_four_bar_exact", "n_four_bar_singular_times", "andrews_squeezer",
           "ANDREWS_INITIAL", "spin_up_beam", "flexible_robot",
           "eigenvalues_vs_speed", "stability_speeds", "upright_state",
           "from_urdf", "URDFDefinition", "URDFError", "JointInfo", "Visual",
           "from_mjcf", "MJCFDefinition", "MJCFError",
           "planar_3rrr", "PLANAR_3RRR_GEOMETRY", "planar_3rrr_ik", "newton_ik",
           "quintic_pose", "sinusoid_pose", "stewart_platform", "STEWART_GEOMETRY",
           "stewart_anchors", "stewart_leg_lengths", "out_parallel_6dof",
           "OUT_PARALLEL_GEOMETRY", "OUT_PARALLEL_INERTIA", "out_parallel_anchors",
           "out_parallel_ik", "OutParallelMachine", "read_out_parallel_machine",
           "MACHINE_KEYS", "oc3_spar", "oc3_settle", "oc3_static_offsets", "oc3_tower",
           "oc3_tower_member", "oc3_rna_node_mass", "OC3_SPAR_OPTIONS", "oc3_operating_point",
           "OperatingPoint",
           "seatbelt_sensor", "seatbelt_motion", "seatbelt_report", "seatbelt_tilt",
           "lock_events", "SeatbeltReport", "SEATBELT_DEFAULTS",
           "oc3_tower_rna_basis"]


class _Builder:
    """A built-in model's builder, imported when first called.

    ``title`` is the title of the model built with its default options
    (``kanedyn list`` shows it without importing SymPy; a test checks it
    against ``builder().title``).
    """

    def __init__(self, name):
        self.__name__ = self.__qualname__ = name
        self.title = _TITLES[name]

    @property
    def function(self):
        """The builder function itself."""
        return __getattr__(self.__name__)

    @property
    def __signature__(self):
        import inspect
        return inspect.signature(self.function)

    @property
    def __doc__(self):
        return self.function.__doc__

    def __call__(self, *args, **kwargs):
        return self.function(*args, **kwargs)

    def __repr__(self):
        return f"<builder {self.__name__} of kanedyn.models>"




#: builder -> title of the model built with its default options (kanedyn list)
_TITLES = {
    'pendulum': 'simple pendulum (point mass on a massless rod)',
    'n_link_pendulum_on_cart': '3-link pendulum on a cart pushed by F(t)',
    'chain3d': '3D chain of 5 links, revolute joints of alternating axes',
    'rolling_disk': 'thin disk rolling without slip (nonholonomic)',
    'chaplygin_sleigh': 'Chaplygin sleigh (knife edge, nonholonomic)',
    'four_bar': 'planar four-bar linkage under gravity (closed loop)',
    'whipple_bicycle': 'Whipple bicycle, benchmark parameters (Meijaard et al. 2007)',
    'sphere_slug': 'particle sliding inside a sphere with friction, zero g',
    'slug_ellipsoid': 'slug on the wall of a spinning, translating ellipsoidal tank (zero g)',
    'block_on_incline': 'block on a plane whose inclination increases: stick-slip',
    'bead_in_tube': 'bead in a spinning square tube: floor and wall friction, slip then stick',
    'bouncing_ball': 'ball bouncing on a floor with restitution',
    'ladder': 'ladder sliding against a rough wall and floor',
    'falling_rod': 'rod falling on a rough floor: impacts with friction',
    'nonholonomic_particle': "particle with z' = y x' on a spring (nonholonomic vs vakonomic)",
    'sphere_on_turntable': 'uniform sphere rolling on a spinning turntable',
    'rod_bead': 'bead on a uniformly turning horizontal rod (vector guide)',
    'pin_slot': 'crank and slotted lever, joints as vector constraints',
    'knife_edge': 'Chaplygin sleigh, knife edge as a vector constraint',
    'rolling_disk_contact': 'rolling disk as a free body with a vector contact constraint',
    'block_wedge': 'block on a wedge on a smooth floor (vector constraints)',
    'snake': '5-link snake robot on passive wheels, serpenoid joint torques',
    'shuttle_arm': ('Shuttle arm (SRMS, 6 revolute joints, with a Hubble-class payload '
                    '(11,110 kg)), PD-tracked manoeuvre'),
    'n_four_bar': ('IFToMM benchmark A02: 10 four-bar linkages in a row (singular '
                   "positions; the benchmark's n is 40)"),
    'andrews_squeezer': "Andrews' squeezing mechanism: 7 bodies, 6 loop-closure constraints",
    'spin_up_beam': 'spin-up of a cantilever on a hub to 6 rad/s, with geometric stiffening',
    'flexible_robot': ('elastic one-dof robot: hub, flexible link and payload, rest-to-rest '
                       'torque pulse'),
    'planar_3rrr': 'planar 3-RRR parallel manipulator (horizontal)',
    'stewart_platform': 'Stewart-Gough platform, six UPS legs, under gravity',
    'out_parallel_6dof': ('6-dof out-parallel manipulator: ball-screw carriages on rails, struts,'
                          ' under gravity'),
    'oc3_spar': ('OC3-Hywind spar floating wind turbine (2 tower modes, tower damping 1 %'
                 ' (isolated), linear mooring, still sea)'),
    'seatbelt_sensor': ('seat-belt inertial sensor: spherical pendulum in a housing on a '
                        'moving vehicle'),
}

#: name -> (builder, {option: type})
REGISTRY = {
    "pendulum": (_Builder("pendulum"), {"tension": bool, "torque": bool}),
    "n-link-pendulum-on-cart": (_Builder("n_link_pendulum_on_cart"), {"n": int}),
    "chain3d": (_Builder("chain3d"), {"n": int, "style": str}),
    "rolling-disk": (_Builder("rolling_disk"), {"normal_force": bool}),
    "chaplygin-sleigh": (_Builder("chaplygin_sleigh"), {"lateral_force": bool}),
    "four-bar": (_Builder("four_bar"), {}),
    "whipple-bicycle": (_Builder("whipple_bicycle"), {"steer_torque": bool}),
    "sphere-slug": (_Builder("sphere_slug"), {}),
    "slug-ellipsoid": (_Builder("slug_ellipsoid"), {}),
    "block-on-incline": (_Builder("block_on_incline"), {}),
    "bead-in-tube": (_Builder("bead_in_tube"), {"omega": float}),
    "bouncing-ball": (_Builder("bouncing_ball"), {"restitution": float}),
    "ladder": (_Builder("ladder"), {"frictionless": bool, "angle": float}),
    "falling-rod": (_Builder("falling_rod"), {"angle": float, "restitution": float, "mu": float,
                                   "law": str}),
    "nonholonomic-particle": (_Builder("nonholonomic_particle"), {}),
    "sphere-turntable": (_Builder("sphere_on_turntable"), {}),
    "rod-bead": (_Builder("rod_bead"), {}),
    "pin-slot": (_Builder("pin_slot"), {}),
    "knife-edge": (_Builder("knife_edge"), {}),
    "rolling-disk-contact": (_Builder("rolling_disk_contact"), {}),
    "block-wedge": (_Builder("block_wedge"), {}),
    "snake": (_Builder("snake"), {"n": int}),
    "shuttle-arm": (_Builder("shuttle_arm"), {"payload": bool, "flexible_booms": bool,
                                             "torque_input": bool}),
    "n-four-bar": (_Builder("n_four_bar"), {"n": int}),
    "andrews-squeezer": (_Builder("andrews_squeezer"), {}),
    "spin-up-beam": (_Builder("spin_up_beam"), {"omega_s": float, "stiffening": bool,
                                                "n_modes": int, "n_elements": int,
                                                "length": float, "EI": float,
                                                "mass_per_length": float, "EA": float,
                                                "spin_up_time": float}),
    "flexible-robot": (_Builder("flexible_robot"), {"n_modes": int, "n_elements": int,
                                        "stiffening": bool, "hub_damping": float,
                                        "pulse_payload": float, "torque_input": bool,
                                        "length": float, "EI": float,
                                        "mass_per_length": float, "EA": float}),
    "3rrr": (_Builder("planar_3rrr"), {"gravity": bool}),
    "stewart-platform": (_Builder("stewart_platform"), {}),
    "out-parallel-6dof": (_Builder("out_parallel_6dof"), {"force_input": bool}),
    "oc3-spar": (_Builder("oc3_spar"), _oc3_options.OC3_SPAR_OPTIONS),
    "seatbelt-sensor": (_Builder("seatbelt_sensor"),
                        {"limit": str, "pulse": str, "peak_g": float, "duration": float,
                         "direction": float, "roll_rate": float, "filter": str,
                         "pivot_force": bool}),
}



#: name -> {option: unit} of the options that carry one (``kanedyn list MODEL``)
OPTION_UNITS = {
    "spin-up-beam": {"omega_s": "rad/s", "length": "m", "EI": "N m^2",
                     "mass_per_length": "kg/m", "EA": "N", "spin_up_time": "s"},
    "flexible-robot": {"hub_damping": "N m s/rad", "pulse_payload": "kg", "length": "m",
                       "EI": "N m^2", "mass_per_length": "kg/m", "EA": "N"},
}


def available():
    """``[(name, title)]`` of the built-in models."""
    return [(name, builder.title) for name, (builder, _) in REGISTRY.items()]


def similar_models(name):
    """Built-in model names like ``name`` (a mistyped one): those that contain it,
    then the close spellings, at most three."""
    import difflib
    text = str(name).strip().lower().replace("_", "-")
    found = [m for m in REGISTRY if text and text in m]
    found += difflib.get_close_matches(text, list(REGISTRY), n=3, cutoff=0.6)
    return list(dict.fromkeys(found))[:3]


def unknown_model_text(name):
    """``"unknown model 'x'; did you mean y?"`` (the suggestion when there is one)."""
    similar = similar_models(name)
    hint = f"; did you mean {' or '.join(similar)}?" if similar else ""
    return f"unknown model {name!r}{hint}"


def options_adding(name, constant, options=None):
    """The options of built-in model ``name`` that would give it the constant
    named ``constant``, which it lacks with ``options``.

    Each option not in ``options`` that is a switch (``bool``: its other
    value) or off by default (``None``: the value 1.0 or 1) is tried by
    building the model with it (the SymPy definition, not its derivation);
    an option whose trial value the model refuses is passed over.

    Parameters
    ----------
    name : str
        One of :data:`REGISTRY`.
    constant : str
        The constant's name, e.g. ``"c_h"``.
    options : dict, optional
        The options given (those are not tried).

    Returns
    -------
    list of str
        ``["hub_damping"]``; empty when no such option adds it, or the
        model has it with ``options``.
    """
    import inspect

    from ._pending import build_now
    builder, allowed = REGISTRY[name]
    options = dict(options or {})
    defaults = inspect.signature(builder).parameters

    def has_it(chosen):
        return constant in {str(c) for c in build_now(name, chosen, builder).constants}

    if has_it(options):
        return []
    found = []
    for option, kind in allowed.items():
        default = defaults[option].default
        if option in options:
            continue
        if kind is bool:
            trial = not default
        elif default is None and kind in (int, float):
            trial = kind(1)
        else:
            continue
        try:
            if has_it(dict(options, **{option: trial})):
                found.append(option)
        except (ModelError, ValueError, TypeError):  # the trial value refused
            continue
    return found


def build(name, lazy=True, **options):
    """A fresh :class:`ModelDefinition` of the named built-in model.

    Parameters
    ----------
    name : str
        One of :data:`REGISTRY` (``kanedyn list``).
    lazy : bool
        ``True`` (the default): when the model's compiled numerical model
        (the C backend, these options) is in the derivation cache, a
        :class:`PendingDefinition`: a :class:`ModelDefinition` whose SymPy
        objects are built when a field is first read, so that
        ``build(name).numeric(backend="c")`` in a second process imports no
        SymPy; its options were checked by the builder when the entry was
        written.  When the model is not in the cache, the definition is built
        here.  ``False``: the definition is always built here.  Either way
        errors in option names and values are raised by this call.
    **options
        Model options, e.g. ``n=8`` for ``chain3d``.

    Returns
    -------
    ModelDefinition
        A :class:`PendingDefinition` (a subclass) while not yet built.
    """
    try:
        builder, allowed = REGISTRY[name]
    except KeyError:
        raise ModelError(f"{unknown_model_text(name)} (available: "
                         f"{', '.join(REGISTRY)})") from None
    unknown = set(options) - set(allowed)
    if unknown:
        raise ModelError(f"model {name} has no option(s) {sorted(unknown)}; "
                         f"its options: {sorted(allowed) or 'none'}")
    if not isinstance(lazy, bool):
        raise ModelError(f"build({name!r}): lazy must be True or False, not {lazy!r}")
    from ._pending import PendingDefinition, build_now
    if lazy:
        pending = PendingDefinition(name, options, builder)  # imported when it builds
        if pending.in_cache():
            return pending
    return build_now(name, options, builder)


__getattr__, __dir__ = _lazy_attributes(__name__, _LAZY, globals(), __all__,
                                        neighbours=_NAMESPACES)
