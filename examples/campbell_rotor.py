"""Campbell diagram of a three-bladed rotor: collective and whirl modes in multiblade coordinates.

What it shows: ``kd.campbell`` follows the modes of a rotating system over rotor speed.
The rotor (``kd.models.lag_rotor``) has three rigid blades on lag hinges with springs,
on a hub that moves sideways on springs.  At each speed the steady motion is found with
the rotor speed held, the model is linearized exactly there, and the blades' lag angles
are replaced by their multiblade coordinates (collective, cosine and sine: Coleman's
transformation, MBC3), which makes the linear system time invariant.  The modes are
followed from speed to speed by the modal assurance criterion of their shapes.  On a
rigid hub the lag mode at w splits into the collective (w) and the forward (w + Omega)
and backward (w - Omega) whirl; the flexible hub couples the whirl modes with its own
two, and the collective, which the hub does not feel, crosses them.

    python examples/campbell_rotor.py                     # 0 to 4 rad/s
    python examples/campbell_rotor.py --plot campbell.png # the diagram
"""

import argparse

import numpy as np

import kanedyn as kd

BLADES = [["zeta_1"], ["zeta_2"], ["zeta_3"]]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-speed", type=float, default=4.0, help="rad/s")
    parser.add_argument("--plot", metavar="FILE", help="save the diagram (needs matplotlib)")
    args = parser.parse_args(argv)

    definition = kd.models.lag_rotor()
    eom = definition.derive()
    speeds = np.linspace(0.0, args.max_speed, 41)
    k_h = definition.symbols["k_h"]
    rigid_hub = definition.numeric(eom, constants={k_h: 1e11})
    on_springs = definition.numeric(eom)
    common = dict(speed="Omega", azimuth="psi", rotating=BLADES, constant_speed=True)
    split = kd.campbell(rigid_hub, speeds, np.zeros(rigid_hub.n_states), n_modes=3, **common)
    coupled = kd.campbell(on_springs, speeds, np.zeros(on_springs.n_states), **common)

    print(definition.title)
    for name in ("zeta_1 collective", "zeta_1 forward whirl", "zeta_1 backward whirl"):
        f = split.frequencies[-1, split.mode(name)] * 2 * np.pi
        print(f"  rigid hub, {name:22s} at {speeds[-1]:.1f} rad/s: {f:.5f} rad/s")
    for j, name in enumerate(coupled.labels):
        print(f"  on springs, {name:22s} {coupled.frequencies[0, j]:.4f} -> "
              f"{coupled.frequencies[-1, j]:.4f} Hz, smallest MAC "
              f"{np.nanmin(coupled.mac[1:, j]):.3f}")
    if args.plot:
        coupled.plot(args.plot, speed_unit="rad/s", frequency_unit="rad/s",
                     title="Three lag-hinged blades on a hub on springs (constant rotor speed)")
    return dict(speeds=speeds, split=split, coupled=coupled)


if __name__ == "__main__":
    main()
