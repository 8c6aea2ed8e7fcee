"""Which way the 3D viewer draws up: the user's word, the model's declared
gravity, the bodies' weights (never the sum of all forces), else +z; and the
OC3-Hywind turbine, whose buoyancy exceeds its weight, drawn nacelle on top.

The screenshot test renders the page in the system Chromium (as
tests/test_viewer.py does) and finds the rotor-nacelle assembly's colour above
the spar's in the picture.
"""

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from test_viewer import CHROMIUM, _browser_pages, _pixels

import kanedyn as kd
from kanedyn.io import PALETTE, scene_data, up_direction


def _floater(buoyancy_factor=3.0, up_axis=None):
    """A particle under its weight -m g N.z and a larger buoyancy +B N.z (at a
    point of its own, as a hydrostatic load is), on a spring along N.x."""
    x, z, u, w = me.dynamicsymbols("x z u w")
    m, g, k = sm.symbols("m g k", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.x + z * N.z)
    P.set_vel(N, u * N.x + w * N.z)
    ball = me.Particle("ball", P, m)
    loads = [(P, -m * g * N.z), (P, buoyancy_factor * m * g * N.z - k * x * N.x)]
    eom = kd.kane(frame=N, q_ind=[x, z], u_ind=[u, w], kd_eqs=[x.diff() - u, z.diff() - w],
                  bodies=[ball], loads=loads)
    model = eom.numeric(constants={m: 2.0, g: 9.81, k: 10.0})
    res = kd.simulate(model, (0, 0.5), [0.1, 0.0, 0.0, 0.0], t_eval=np.linspace(0, 0.5, 6))
    assert res.success
    return res


def test_up_is_against_the_weights_not_the_resultant():
    """The resultant (2 m g up) would put up at -z; the weight says +z."""
    scene = scene_data(_floater())
    assert scene["up"] == [0.0, 0.0, 1.0]
    assert scene["up_note"] == "against gravity: the weights of ball"


def test_the_users_word_first_then_declared_gravity():
    res = _floater()
    assert scene_data(res, up="-y")["up"] == [0.0, -1.0, 0.0]
    assert scene_data(res, up="-y")["up_note"] == "given"
    eom = res.model._eom
    up, note = up_direction("auto", eom, {"m": 2.0, "g": 9.81})
    assert up.tolist() == [0.0, 0.0, 1.0]
    # a declared gravity (a model definition's) wins over the weights
    eom._label(gravity=(-9.81, 0.0, 0.0))
    up, note = up_direction("auto", eom, {})
    assert up.tolist() == [1.0, 0.0, 0.0] and note == "against the model's declared gravity"
    with pytest.raises(kd.OptionError, match="up must be 'auto', an axis name or 3 numbers"):
        up_direction((0, 0, 0), eom, {})


def test_no_gravity_is_said():
    """A model with no weight (a force at the mass centre that is not proportional
    to the mass) is drawn with +z up, and the note says that nothing told."""
    x, u = me.dynamicsymbols("x u")
    m, c = sm.symbols("m c", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", x * N.y)
    P.set_vel(N, u * N.y)
    eom = kd.kane(frame=N, q_ind=[x], u_ind=[u], kd_eqs=[x.diff() - u],
                  bodies=[me.Particle("cart", P, m)], loads=[(P, -c * N.y)])
    up, note = up_direction("auto", eom, {"m": 1.0, "c": 1.0})
    assert up.tolist() == [0.0, 0.0, 1.0]
    assert note.startswith("the model declares no gravity and has no weights")


@pytest.fixture(scope="module")
def turbine_page(tmp_path_factory):
    definition = kd.models.build("oc3-spar")
    model = definition.numeric(backend="numpy")
    res = kd.simulate(model, (0.0, 2.0), definition.initial(model),
                      t_eval=np.linspace(0.0, 2.0, 5))
    assert res.success
    scene = scene_data(res, visuals=definition.shapes())
    path = tmp_path_factory.mktemp("oc3") / "oc3.html"
    res.animate(path, visuals=definition.shapes(), title="oc3-spar")
    return definition, scene, path


def test_turbine_scene_nacelle_above_platform(turbine_page):
    definition, scene, _ = turbine_page
    # hydrostatic buoyancy exceeds the weight (mooring's pull makes up the rest)
    assert scene["up"] == [0.0, 0.0, 1.0]
    assert scene["up_note"] == "against the model's declared gravity"
    bodies = {b["name"]: b for b in scene["bodies"]}
    height = {name: np.array(b["position"]).reshape(-1, 3) @ scene["up"]
              for name, b in bodies.items()}
    assert np.all(height["rna"] > height["platform"] + 150)  # m: hub 90 m, spar CM -90 m
    # drawn as declared: the spar's three cylinders, the nacelle, hub and rotor disc
    kinds = {name: [s["kind"] for s in b["shapes"]] for name, b in bodies.items()}
    assert kinds["platform"] == ["cylinder"] * 3
    assert kinds["rna"] == ["box", "sphere", "cylinder"]
    disc = bodies["rna"]["shapes"][2]
    assert disc["radius"] == pytest.approx(63.0) and disc["opacity"] < 1


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="no chromium executable found (Debian: "
                    "apt-get install chromium); the page is not tested in a browser")
def test_turbine_screenshot_nacelle_above_platform(turbine_page):
    """In the picture, the rotor-nacelle assembly's colour (the viewer's third)
    lies above the spar's (its first)."""
    _, scene, path = turbine_page
    ((errors, counts, (shot,), note),) = _browser_pages(
        [path], times=[1.0], probe="document.querySelector('.kd-scale').textContent")
    assert errors == [] and counts["bodies"] == 3
    assert "up: +z (against the model's declared gravity)" in note
    pixels = _pixels(shot)[:-60]  # the 3D view, not the bar of controls

    def rows_of(hex_color):
        rgb = np.array([int(hex_color[i:i + 2], 16) for i in (1, 3, 5)])
        dominant = int(np.argmax(rgb))
        others = [i for i in range(3) if i != dominant]
        shade = pixels[..., dominant] - pixels[..., others].max(axis=-1)
        rows, _ = np.nonzero(shade > 40)  # shaded but still of the hue
        return rows

    platform, rna = rows_of(PALETTE[0]), rows_of(PALETTE[2])
    assert platform.size > 200 and rna.size > 200
    assert np.median(rna) < np.median(platform) - 100  # px: image rows grow downwards
