"""The ``oc3-spar`` model's options and their types (no heavy imports: ``kanedyn list``)."""

__all__ = ["OC3_SPAR_OPTIONS"]

#: option -> type, for the registry and ``kanedyn run oc3-spar --set name=value``
OC3_SPAR_OPTIONS = {
    "tower_modes": int, "tower_elements": int, "stiffening": bool,
    "tower_damping": float, "tower_damping_reference": str,
    "hydrostatics": str, "added_mass": str, "linear_damping": bool, "drag": bool,
    "sea": str, "wave_height": float, "wave_period": float, "seed": int,
    "mooring": str, "wind_speed": float, "turbulence": float,
    "tmdi": str, "tmd_mass_ratio": float, "tmd_frequency": float, "tmd_damping": float,
    "inertance_ratio": float, "inerter_height": float, "rna_offset": bool,
    "rotor": str, "controller": str, "drivetrain": str, "aero": str, "blades": str,
}
