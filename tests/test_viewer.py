"""The 3D animation: scene data against the models' own kinematics, and the page
in a real headless Chromium.

The poses of the scene come from the model's program (named intermediates);
the tests compare them with closed forms written here (a pendulum bob at
``(l sin q, -l cos q)``, a compound pendulum's quaternion about ``z``), with
SciPy's rotation-matrix-to-quaternion conversion, and a flexible member's
tip node (from its mode shapes) with the payload particle riding on it (from
the program).  The browser test loads the written page from ``file://`` with
the system Chromium, driven by Playwright, and compares two screenshots.
"""

import shutil
import struct

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from scipy.spatial.transform import Rotation

import kanedyn as kd
from kanedyn.cli import main
from kanedyn.io import page_html, quaternions, read_mesh, read_obj, read_stl, scene_data

CHROMIUM = next((p for p in (shutil.which("chromium"), shutil.which("chromium-browser"),
                             "/usr/bin/chromium") if p and shutil.os.path.exists(p)), None)


def _run(name, t_end, points=101, **options):
    definition = kd.models.build(name, **options)
    eom = definition.derive()
    model = definition.numeric(eom)
    y0 = definition.initial(model)
    res = kd.simulate(model, (0, t_end), y0, t_eval=np.linspace(0, t_end, points),
                      rtol=1e-9, atol=1e-9)
    assert res.success, res.message
    return definition, res


def _compound_pendulum(a=0.3, b=0.1, c=0.05, m=2.0, l=0.8, name="rod", centre="G"):
    """A rigid body on a pivot about N.z; its inertia is a solid ellipsoid's (a, b, c);
    ``name`` of the body, ``centre`` of its mass centre."""
    q, u = me.dynamicsymbols("q u")
    g = sm.symbols("g")
    N, A = me.ReferenceFrame("N"), me.ReferenceFrame("A")
    A.orient_axis(N, N.z, q)
    A.set_ang_vel(N, u * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    G = O.locatenew(centre, -l / 2 * A.y)
    G.v2pt_theory(O, N, A)
    inertia = me.inertia(A, m * (b**2 + c**2) / 5, m * (a**2 + c**2) / 5,
                         m * (a**2 + b**2) / 5)
    body = me.RigidBody(name, G, A, m, (inertia, G))
    eom = kd.kane(frame=N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u], bodies=[body],
                  loads=[(G, -m * g * N.y)])
    model = eom.numeric(constants={g: 9.81})
    res = kd.simulate(model, (0, 2), [1.0, 0.0], t_eval=np.linspace(0, 2, 81), rtol=1e-9,
                      atol=1e-9)
    return res, body, G, (a, b, c), l


# ---------------------------------------------------------------- scene data
def test_pendulum_bob_at_l_sin_q_minus_l_cos_q():
    _, res = _run("pendulum", 3.0)
    scene = scene_data(res)
    (bob,) = scene["bodies"]
    pos = np.array(bob["position"]).reshape(-1, 3)
    q = res["q"]
    expected = np.column_stack([np.sin(q), -np.cos(q), np.zeros_like(q)])  # l = 1
    assert pos.shape == (len(res.t), 3)
    np.testing.assert_allclose(pos, expected, atol=2e-6)
    assert scene["up"] == [0.0, 1.0, 0.0]  # gravity is -m g N.y
    assert bob["default_shape"] and bob["shapes"][0]["kind"] == "sphere"
    assert scene["skeleton"]["segments"] == [[0, 1]]  # the rod from O to the bob


def test_rigid_body_pose_and_default_ellipsoid():
    res, body, G, axes, l = _compound_pendulum()
    scene = scene_data(res)
    (rod,) = scene["bodies"]
    q = res["q"]
    quat = np.array(rod["quaternion"]).reshape(-1, 4)
    expected = np.column_stack([0 * q, 0 * q, np.sin(q / 2), np.cos(q / 2)])
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", quat, expected)), 1, atol=2e-6)
    pos = np.array(rod["position"]).reshape(-1, 3)
    np.testing.assert_allclose(pos[:, :2], np.column_stack([l / 2 * np.sin(q),
                                                            -l / 2 * np.cos(q)]), atol=2e-6)
    shape = rod["shapes"][0]
    # the ellipsoid of equal inertia of a solid ellipsoid is that ellipsoid
    R = Rotation.from_quat(shape["quaternion"]).as_matrix()
    semi = np.array(shape["semi_axes"])
    for k, length in enumerate(axes):  # body axis k: the shape axis along it
        j = int(np.argmax(np.abs(R[k])))
        assert semi[j] == pytest.approx(length, rel=1e-9)


def test_quaternions_match_scipy():
    R = Rotation.random(200, random_state=4)
    q = quaternions(R.as_matrix())
    ref = R.as_quat()  # (x, y, z, w)
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", q, ref)), 1, atol=1e-12)
    steps = np.einsum("ij,ij->i", q[1:], q[:-1])
    assert np.all(steps >= 0)  # neighbours never flip sign


@pytest.mark.slow
def test_flexible_tip_node_carries_the_payload():
    _, res = _run("flexible-robot", 1.0, points=41)
    scene = scene_data(res)
    (link,) = scene["flexible"]
    nodes = np.array(link["nodes"]).reshape(len(res.t), link["n_nodes"], 3)
    payload = [b for b in scene["bodies"] if b["name"] == "payload"][0]
    np.testing.assert_allclose(nodes[:, -1], np.array(payload["position"]).reshape(-1, 3),
                               atol=2e-6)
    assert np.ptp(nodes[:, -1, 1]) > 0.1  # the member turns with the hub


def test_contact_plane_and_translation_not_a_link():
    _, res = _run("bouncing-ball", 1.0)
    scene = scene_data(res)
    (floor,) = scene["surfaces"]
    assert floor["kind"] == "plane" and floor["normal"] == [0.0, 0.0, 1.0]
    assert scene["skeleton"]["segments"] == []  # the ball's fall is no rod
    _, res = _run("n-link-pendulum-on-cart", 1.0, n=2)
    segments = scene_data(res)["skeleton"]["segments"]
    assert len(segments) == 2  # two rods; the cart's track is not drawn as one


def test_declared_shapes_and_traces():
    res, body, G, _, _ = _compound_pendulum()
    shapes = [kd.visuals.Box(body, (0.1, 0.8, 0.05), color="#336699"),
              kd.visuals.Cylinder(body, 0.02, 0.1, axis="z", offset=(0, 0.4, 0))]
    scene = scene_data(res, visuals=shapes, trace=[G])
    kinds = [s["kind"] for s in scene["bodies"][0]["shapes"]]
    assert kinds == ["box", "cylinder"] and not scene["bodies"][0]["default_shape"]
    np.testing.assert_allclose(scene["traces"][0]["points"], scene["bodies"][0]["position"])
    # the legend's colour is the one drawn: the declared shape's, for both shapes
    assert scene["bodies"][0]["color"] == "#336699"
    assert [s["color"] for s in scene["bodies"][0]["shapes"]] == ["#336699"] * 2


def test_bad_shapes_name_the_body_and_option():
    res, body, _, _, _ = _compound_pendulum()
    with pytest.raises(kd.ModelError, match="box of body rod: lengths"):
        kd.visuals.Box(body, (0.1, -1, 0.1))
    with pytest.raises(kd.ModelError, match="color"):
        kd.visuals.Sphere(body, 0.1, color="red")
    with pytest.raises(kd.ModelError, match="does not exist"):
        kd.visuals.Mesh(body, "no-such-file.stl")
    other = me.Particle("stranger", me.Point("S"), 1.0)
    with pytest.raises(kd.ModelError, match="stranger is not a body"):
        scene_data(res, visuals=[kd.visuals.Sphere(other, 0.1)])
    with pytest.raises(kd.OptionError, match="up must be"):
        scene_data(res, up="sideways")


def test_meshes_stl_binary_text_and_obj(tmp_path):
    tri = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 0], [0, 1, 0], [0, 0, 1]]],
                   dtype="<f4")
    binary = tmp_path / "two.stl"
    binary.write_bytes(b"\0" * 80 + struct.pack("<I", 2) + b"".join(
        np.zeros(3, "<f4").tobytes() + t.tobytes() + b"\0\0" for t in tri))
    v, f = read_stl(binary)
    np.testing.assert_allclose(v[f], tri)
    text = tmp_path / "two_text.stl"
    text.write_text("solid t\n" + "".join(
        "facet normal 0 0 0\nouter loop\n" + "".join(f"vertex {a} {b} {c}\n" for a, b, c in t)
        + "endloop\nendfacet\n" for t in tri) + "endsolid t\n")
    v2, f2 = read_stl(text)
    np.testing.assert_allclose(v2[f2], tri)
    obj = tmp_path / "quad.obj"
    obj.write_text("# a square\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    v3, f3 = read_obj(obj)
    assert f3.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert read_mesh(obj)["n_triangles"] == 2
    obj.write_text("v 0 0 0\nv 1 0\n")
    with pytest.raises(kd.ModelError, match="quad.obj, line 2"):
        read_obj(obj)


def test_page_is_self_contained(tmp_path):
    _, res = _run("pendulum", 1.0, points=21)
    path = res.animate(tmp_path / "run.html")
    html = path.read_text()
    assert "application/json" in html and "three.js 0.187.0" in html
    outside_blobs = [part.split("</script>", 1)[-1]
                     for part in html.split('type="application/octet-stream">')]
    assert not any("http://" in p or "https://" in p for p in outside_blobs)
    assert "eval(" not in page_html(scene_data(res))
    with pytest.raises(kd.OptionError, match=".html"):
        res.animate(tmp_path / "run.png")


#: a body name, a point name and a title that end the scene's <script> early (the
#: first broke the page silently), or would run script if put into HTML as markup
HOSTILE = ("<!--<script>", "</script><script>window.kdRan=1</script>&amp;<!--",
           '<img src=x onerror="window.kdRan=2">&amp; \u2028')


def _hostile_page(tmp_path):
    """A compound pendulum whose body and traced point bear hostile names."""
    res, _, G, _, _ = _compound_pendulum(name=HOSTILE[0], centre=HOSTILE[1])
    return res.animate(tmp_path / "hostile.html", trace=[G], title=HOSTILE[2])


def test_names_cannot_break_out_of_the_scene_script(tmp_path):
    """The scene's JSON holds no '<', '>' or '&' (nor U+2028/9), so no name can end
    its <script> element or start a comment in it, and it reads back unchanged."""
    html = _hostile_page(tmp_path).read_text(encoding="utf-8")
    start = html.index('<script id="kd-scene" type="application/json">')
    data = html[start:].split(">", 1)[1].split("</script>", 1)[0]
    assert not any(c in data for c in "<>&\u2028\u2029")
    import json
    scene = json.loads(data)
    assert scene["bodies"][0]["name"] == HOSTILE[0]
    assert scene["traces"][0]["name"] == HOSTILE[1] and scene["title"] == HOSTILE[2]
    assert "<title>&lt;img src=x onerror=&quot;window.kdRan=2&quot;&gt;&amp;amp;" in html


def test_cli_run_animate(tmp_path):
    out = tmp_path / "out"
    assert main(["run", "pendulum", "--t-end", "1", "--points", "21", "--quiet",
                 "--animate", "--out", str(out)]) == 0
    assert (out / "pendulum.html").stat().st_size > 100_000


@pytest.mark.slow
def test_inputs_the_positions_need_beyond_the_equations(tmp_path):
    """The seat-belt sensor's equations take the vehicle's accelerations only; its
    housing's place needs the displacement too: refused by name without it, and
    with it (``animation_inputs``) the pendulum goes with the vehicle."""
    definition = kd.models.build("seatbelt-sensor")
    model = definition.numeric(backend="numpy")
    res = kd.simulate(model, (0.0, 0.1), definition.initial(model),
                      t_eval=np.linspace(0.0, 0.1, 11))
    with pytest.raises(kd.ModelError, match=r"need V_x, V_y.*animate\(\.\.\., inputs="):
        scene_data(res)
    scene = scene_data(res, inputs=definition.animation_inputs, visuals=definition.shapes())
    pendulum, housing = scene["bodies"]
    position = np.array(pendulum["position"]).reshape(-1, 3)
    (x, y) = [np.array([definition.animation_inputs[s](t) for t in res.t])
              for s in definition.symbols["motion"].symbols[:2]]
    assert np.ptp(x) > 0.1  # the vehicle travels (m) ...
    length = definition.constants[definition.symbols["L"]]
    assert np.all(np.hypot(position[:, 0] - x, position[:, 1] - y) <= length)  # ... with it
    pivot = np.array(housing["position"]).reshape(-1, 3)  # the housing at the pivot
    np.testing.assert_allclose(pivot[:, :2], np.column_stack([x, y]), atol=1e-6)  # (um)
    # drawn at the sensor's size (rod to the 12 mm rim, housing 6 mm in radius), and
    # the links as thick as the sensor, not its 0.4 m of travel, would have them
    rod, ball = pendulum["shapes"]
    assert (rod["kind"], rod["length"], ball["semi_axes"]) == ("cylinder", 0.012, [0.0025] * 3)
    assert housing["shapes"][0]["radius"] == pytest.approx(0.006)
    assert scene["reach"] == pytest.approx(length) and scene["size"] > 0.1
    with pytest.raises(kd.OptionError, match="must be a function of t or a number"):
        scene_data(res, inputs={definition.symbols["motion"].symbols[0]: "0"})
    assert main(["run", "seatbelt-sensor", "--t-end", "0.05", "--quiet", "--animate",
                 "--backend", "numpy", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "seatbelt-sensor.html").exists()


# ------------------------------------------------------------- in Chromium
def _browser_pages(paths, times, probe=None):
    """Load each page from file:// in headless Chromium; screenshots at ``times``
    (and the value of the JavaScript expression ``probe``, when given)."""
    sync_api = pytest.importorskip("playwright.sync_api",
                                   reason="the browser test needs playwright (the test extra)")
    out = []
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        try:
            for path in paths:
                page = browser.new_page(viewport={"width": 900, "height": 600})
                errors = []
                page.on("console", lambda m: errors.append(m.text) if m.type == "error"
                        else None)
                page.on("pageerror", lambda e: errors.append(str(e)))
                page.goto(path.resolve().as_uri())
                page.wait_for_function("window.kanedynScene && window.kanedynScene.ready",
                                       timeout=60_000)
                counts = page.evaluate("({...window.kanedynScene})")
                shots = []
                for t in times:
                    page.evaluate(f"window.kanedynScene.setTime({t})")
                    shots.append(page.screenshot())
                out.append((errors, counts, shots) if probe is None
                           else (errors, counts, shots, page.evaluate(probe)))
                page.close()
        finally:
            browser.close()
    return out


def _pixels(png):
    from io import BytesIO
    from PIL import Image
    return np.asarray(Image.open(BytesIO(png)).convert("RGB"), dtype=int)


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="no chromium executable found (Debian: "
                    "apt-get install chromium); the page is not tested in a browser")
def test_pages_in_headless_chromium(tmp_path):
    _, pendulum = _run("pendulum", 2.0, points=81)
    first = pendulum.animate(tmp_path / "pendulum.html")
    res, body, G, _, _ = _compound_pendulum()
    mesh = tmp_path / "plate.obj"
    mesh.write_text("v 0 0 0\nv 0.1 0 0\nv 0.1 0.1 0\nv 0 0.1 0\nf 1 2 3 4\n")
    shapes = [kd.visuals.Box(body, (0.05, 0.8, 0.05)), kd.visuals.Mesh(body, mesh)]
    second = res.animate(tmp_path / "rod.html", visuals=shapes, trace=[G])
    _, ball = _run("bouncing-ball", 1.0)
    third = ball.animate(tmp_path / "ball.html")
    pages = _browser_pages([first, second, third], times=[0.0, 0.5])

    (errors, counts, (a, b)), (errors2, counts2, _), (errors3, counts3, _) = pages
    assert errors == [] and errors2 == [] and errors3 == []
    assert (counts["bodies"], counts["shapes"], counts["segments"]) == (1, 1, 1)
    assert counts["frames"] == 81 and counts["t1"] == pytest.approx(2.0)
    assert (counts2["bodies"], counts2["shapes"], counts2["traces"]) == (1, 2, 1)
    assert (counts3["bodies"], counts3["surfaces"]) == (1, 1)

    A, B = _pixels(a), _pixels(b)
    view = (slice(0, A.shape[0] - 60), slice(0, A.shape[1]))  # the 3D view, not the bar
    changed = np.any(np.abs(A[view] - B[view]) > 30, axis=-1)
    assert changed.sum() > 300  # the bob and its rod moved
    assert changed.mean() < 0.2  # ... and only they: the view itself stayed
    rows, cols = np.nonzero(changed)
    assert np.ptp(cols) > 50  # the bob swung sideways across the picture


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="no chromium executable found (Debian: "
                    "apt-get install chromium); the page is not tested in a browser")
def test_hostile_names_shown_as_text_in_chromium(tmp_path):
    """The page of a body named '<!--<script>' (which used to stay blank) loads,
    shows each name as text, and runs no script from them."""
    page = _hostile_page(tmp_path)
    ((errors, counts, _, probe),) = _browser_pages([page], times=[0.0], probe="""({
        ran: window.kdRan === undefined ? null : window.kdRan,
        legend: [...document.querySelectorAll('.kd-legend > div')].map((d) => d.textContent),
        title: document.querySelector('.kd-title').textContent,
        documentTitle: document.title,
        images: document.images.length})""")
    assert errors == []
    assert (counts["bodies"], counts["traces"]) == (1, 1)
    assert probe == {"ran": None, "legend": [f"{HOSTILE[0]} (default shape)",
                                             f"path of {HOSTILE[1]}"],
                     "title": HOSTILE[2], "documentTitle": HOSTILE[2],
                     "images": 0}
