// kanedyn's animation viewer: the scene code shared by the page (_viewer_page.js) and
// the notebook widget (_viewer_widget.js); kanedyn.io._page joins this file with one of
// them into one module.  three.js comes gzip-compressed and base64-encoded from the
// page or the widget's module: nothing is fetched from the network.

async function kdUnpack(b64) {
  const bytes = Uint8Array.from(atob(b64.trim()), (c) => c.charCodeAt(0));
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
  return await new Response(stream).text();
}

function kdModuleURL(source) {
  return URL.createObjectURL(new Blob([source], { type: "text/javascript" }));
}

// three.js from {core, main, orbit}: base64 of gzip of three.core.js, three.module.js
// and OrbitControls.js, imported from blob: URLs
async function kdLoadThree(sources) {
  const core = kdModuleURL(await kdUnpack(sources.core));
  const main = kdModuleURL((await kdUnpack(sources.main)).replaceAll("'./three.core.js'",
                                                                   JSON.stringify(core)));
  const orbit = kdModuleURL((await kdUnpack(sources.orbit)).replaceAll(
    "from 'three'", "from " + JSON.stringify(main)));
  const THREE = await import(main);
  const { OrbitControls } = await import(orbit);
  return { THREE, OrbitControls };
}

// the viewer's elements inside root (classes, not ids: a notebook shows several)
function kdMarkup(root) {
  const add = (parent, tag, cls, text) => {
    const e = parent.appendChild(document.createElement(tag));
    if (cls) e.className = cls;
    if (text) e.textContent = text;
    return e;
  };
  root.classList.add("kd-viewer");
  const parts = { root, view: add(root, "div", "kd-view") };
  const info = add(root, "div", "kd-info");
  parts.title = add(info, "h1", "kd-title");
  for (const name of ["legend", "scale", "notes", "error"]) parts[name] = add(info, "div", "kd-" + name);
  const bar = add(root, "div", "kd-bar");
  parts.play = add(bar, "button", "kd-play", "Play");
  parts.play.type = "button";
  parts.slider = add(bar, "input", "kd-slider");
  Object.assign(parts.slider, { type: "range", min: "0", max: "1000", step: "1", value: "0" });
  parts.slider.setAttribute("aria-label", "time");
  const label = add(bar, "label", null, "speed ");
  parts.speed = add(label, "select", "kd-speed");
  for (const v of ["0.1", "0.25", "0.5", "1", "2", "4"]) {
    const option = add(parts.speed, "option", null, v + "x");
    option.value = v;
    option.selected = v === "1";
  }
  parts.time = add(bar, "span", "kd-time");
  return parts;
}

function kdFail(parts, err) {
  console.error(err);
  parts.error.textContent = "The animation could not be shown: " + (err && err.message || err);
}

function niceStep(x) {
  const p = Math.pow(10, Math.floor(Math.log10(x)));
  const m = x / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

function decode(b64, Type) {
  const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
  return new Type(bytes.buffer);
}

// draw a scene (kanedyn.io.scene_data) into the elements of kdMarkup; returns the
// viewer's handle (counts of what is drawn, setTime, dispose).  `previous`, a handle
// of the same elements, hands over the camera, the time and play/pause.
function kdBuild(THREE, OrbitControls, scene, parts, previous = null) {
  const T = scene.t;
  const nFrames = T.length;
  const size = scene.size;
  const view = parts.view;
  const listening = new AbortController();
  const signal = listening.signal;
  for (const name of ["legend", "notes", "error"]) parts[name].textContent = "";
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  view.appendChild(renderer.domElement);
  const world = new THREE.Scene();
  world.background = new THREE.Color(0xf4f5f7);
  const up = new THREE.Vector3(...scene.up);
  const camera = new THREE.PerspectiveCamera(40, 1, size * 1e-3, size * 1e3);
  camera.up.copy(up);
  world.add(new THREE.HemisphereLight(0xffffff, 0x8d8d8d, 2.2));
  const sun = new THREE.DirectionalLight(0xffffff, 1.6);
  world.add(sun);

  const counts = { bodies: 0, shapes: 0, fixed: 0, surfaces: 0, flexible: 0, traces: 0,
                   segments: 0, frames: nFrames };
  const updaters = [];
  const material = (color, opacity = 1) => new THREE.MeshStandardMaterial({
    color, roughness: 0.55, metalness: 0.05, transparent: opacity < 1, opacity,
    side: opacity < 1 ? THREE.DoubleSide : THREE.FrontSide });

  // interpolation between frames: (k, a) with t = (1 - a) T[k] + a T[k + 1]
  function locate(t) {
    if (t <= T[0] || nFrames === 1) return [0, 0];
    if (t >= T[nFrames - 1]) return [nFrames - 1, 0];
    let lo = 0, hi = nFrames - 1;
    while (hi - lo > 1) { const mid = (lo + hi) >> 1; if (T[mid] <= t) lo = mid; else hi = mid; }
    const span = T[lo + 1] - T[lo];
    return [lo, span > 0 ? (t - T[lo]) / span : 0];
  }
  const va = new THREE.Vector3(), vb = new THREE.Vector3();
  function vec(arr, k, a, out, stride = 3, i = 0) {
    const o = k * stride + 3 * i;
    out.set(arr[o], arr[o + 1], arr[o + 2]);
    if (a > 0) {
      const p = o + stride;
      vb.set(arr[p], arr[p + 1], arr[p + 2]);
      out.lerp(vb, a);
    }
    return out;
  }
  const qa = new THREE.Quaternion(), qb = new THREE.Quaternion();
  function quat(arr, k, a, out) {
    const o = 4 * k;
    qa.set(arr[o], arr[o + 1], arr[o + 2], arr[o + 3]);
    if (a > 0) {
      qb.set(arr[o + 4], arr[o + 5], arr[o + 6], arr[o + 7]);
      out.slerpQuaternions(qa, qb, a);
    } else out.copy(qa);
    return out;
  }

  // a cylinder between two points (skeleton links, flexible members)
  const yAxis = new THREE.Vector3(0, 1, 0), dir = new THREE.Vector3();
  function rod(radius, color) {
    const mesh = new THREE.Mesh(new THREE.CylinderGeometry(radius, radius, 1, 12),
                                material(color));
    mesh.place = (p, q) => {
      dir.subVectors(q, p);
      const length = dir.length();
      mesh.visible = length > 0;
      if (!mesh.visible) return;
      mesh.position.addVectors(p, q).multiplyScalar(0.5);
      mesh.quaternion.setFromUnitVectors(yAxis, dir.divideScalar(length));
      mesh.scale.set(1, length, 1);
    };
    return mesh;
  }

  function shapeMesh(s) {
    let geometry;
    if (s.kind === "box") geometry = new THREE.BoxGeometry(...s.lengths);
    else if (s.kind === "cylinder") geometry = new THREE.CylinderGeometry(s.radius, s.radius,
                                                                          s.length, 40);
    else if (s.kind === "sphere") geometry = new THREE.SphereGeometry(1, 40, 20);
    else if (s.kind === "mesh") {
      geometry = new THREE.BufferGeometry();
      geometry.setAttribute("position", new THREE.BufferAttribute(
        decode(s.vertices, Float32Array), 3));
      geometry.setIndex(new THREE.BufferAttribute(decode(s.triangles, Uint32Array), 1));
      geometry.computeVertexNormals();
    } else throw new Error("unknown shape kind " + s.kind);
    const mesh = new THREE.Mesh(geometry, material(s.color, s.opacity));
    if (s.kind === "sphere") mesh.scale.set(...s.semi_axes);
    if (s.kind === "mesh") mesh.scale.set(...s.scale);
    mesh.position.set(...s.offset);
    mesh.quaternion.set(...s.quaternion);
    if (s.kind !== "mesh") {
      const edges = new THREE.LineSegments(new THREE.EdgesGeometry(geometry, 30),
        new THREE.LineBasicMaterial({ color: 0x333333, transparent: true, opacity: 0.35 }));
      mesh.add(edges);
    }
    return mesh;
  }

  // bodies; names are the user's text: set as text, never parsed as HTML
  const legend = parts.legend;
  function legendEntry(color, text) {
    const entry = legend.appendChild(document.createElement("div"));
    const swatch = entry.appendChild(document.createElement("span"));
    swatch.className = "swatch";
    swatch.style.background = color;
    entry.appendChild(document.createTextNode(text));
  }
  const bodyGroups = [];
  scene.bodies.forEach((b) => {
    const group = new THREE.Group();
    group.name = b.name;
    b.shapes.forEach((s) => { group.add(shapeMesh(s)); counts.shapes += 1; });
    if (b.oriented && b.shapes.length) {
      const box = new THREE.Box3().setFromObject(group);
      const triad = new THREE.AxesHelper(0.6 * box.getSize(new THREE.Vector3()).length() / 2);
      triad.material.depthTest = false;
      triad.renderOrder = 2;
      group.add(triad);
    }
    world.add(group);
    bodyGroups.push(group);
    counts.bodies += 1;
    updaters.push((k, a) => {
      vec(b.position, k, a, group.position);
      quat(b.quaternion, k, a, group.quaternion);
    });
    legendEntry(b.color, b.name + (b.default_shape ? " (default shape)" : ""));
  });

  // shapes fixed in the inertial frame (a robot's fixed base): placed once
  let fixedGroup = null;
  if (scene.fixed) {
    fixedGroup = new THREE.Group();
    fixedGroup.name = scene.fixed.name;
    scene.fixed.shapes.forEach((s) => { fixedGroup.add(shapeMesh(s)); counts.fixed += 1; });
    world.add(fixedGroup);
    legendEntry(scene.fixed.color, scene.fixed.name);
  }

  // skeleton: the links between the points that locate the bodies
  const sk = scene.skeleton;
  const reach = scene.reach || size;  // the model's own size (links' thickness)
  const skRods = sk.segments.map(() => rod(0.006 * reach, 0x555555));
  skRods.forEach((r) => world.add(r));
  counts.segments = skRods.length;
  const pA = new THREE.Vector3(), pB = new THREE.Vector3();
  updaters.push((k, a) => {
    sk.segments.forEach(([i, j], n) => {
      vec(sk.points, k, a, pA, 3 * sk.n_points, i);
      vec(sk.points, k, a, pB, 3 * sk.n_points, j);
      skRods[n].place(pA, pB);
    });
  });

  // flexible members, deformed
  scene.flexible.forEach((f) => {
    const color = scene.bodies[f.body].color;
    const rods = [];
    for (let i = 0; i + 1 < f.n_nodes; i++) { rods.push(rod(0.012 * reach, color)); }
    rods.forEach((r) => world.add(r));
    counts.flexible += 1;
    updaters.push((k, a) => {
      for (let i = 0; i + 1 < f.n_nodes; i++) {
        vec(f.nodes, k, a, pA, 3 * f.n_nodes, i);
        vec(f.nodes, k, a, pB, 3 * f.n_nodes, i + 1);
        rods[i].place(pA, pB);
      }
    });
  });

  // contact surfaces
  let floorDrawn = false;
  scene.surfaces.forEach((s) => {
    const group = new THREE.Group();
    group.name = s.name;
    if (s.kind === "plane") {
      const n = new THREE.Vector3(...s.normal);
      const patch = new THREE.Mesh(new THREE.PlaneGeometry(s.size, s.size),
                                   material(0x9aa5b1, 0.35));
      patch.quaternion.setFromUnitVectors(new THREE.Vector3(0, 0, 1), n);
      patch.position.set(...s.center);
      const grid = new THREE.GridHelper(s.size, Math.round(s.size / niceStep(size / 8)),
                                        0x667080, 0xb8c0ca);
      grid.quaternion.setFromUnitVectors(yAxis, n);
      grid.position.copy(patch.position);
      group.add(patch, grid);
      if (Math.abs(n.dot(up)) > 0.999) floorDrawn = true;
    } else {
      const mesh = new THREE.Mesh(new THREE.SphereGeometry(1, 48, 24),
                                  material(0x9aa5b1, s.inside ? 0.12 : 0.5));
      mesh.scale.set(...s.semi_axes);
      const wire = new THREE.LineSegments(new THREE.WireframeGeometry(
        new THREE.SphereGeometry(1, 24, 12)), new THREE.LineBasicMaterial(
        { color: 0x667080, transparent: true, opacity: 0.35 }));
      wire.scale.copy(mesh.scale);
      group.add(mesh, wire);
    }
    world.add(group);
    counts.surfaces += 1;
    const moving = s.position.length > 3;
    const place = (k, a) => {
      vec(s.position, moving ? k : 0, moving ? a : 0, group.position);
      quat(s.quaternion, moving ? k : 0, moving ? a : 0, group.quaternion);
    };
    if (moving) updaters.push(place); else place(0, 0);
  });

  // traced points: the path so far
  scene.traces.forEach((tr) => {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute("position", new THREE.Float32BufferAttribute(tr.points, 3));
    const line = new THREE.Line(geometry, new THREE.LineBasicMaterial({ color: tr.color }));
    line.frustumCulled = false;
    world.add(line);
    counts.traces += 1;
    updaters.push((k, a) => geometry.setDrawRange(0, k + 1));
    legendEntry(tr.color, "path of " + tr.name);
  });

  function setFrame(t) {
    const [k, a] = locate(t);
    updaters.forEach((f) => f(k, a));
  }

  // framing: everything drawn, over a few frames; a model that travels far
  // compared with its own size is followed by the camera
  const bounds = new THREE.Box3(new THREE.Vector3(...scene.low), new THREE.Vector3(...scene.high));
  if (fixedGroup) bounds.expandByObject(fixedGroup);
  let instant = 0;
  const centroid = (out) => {
    out.set(0, 0, 0);
    bodyGroups.forEach((g) => out.add(g.position));
    return out.divideScalar(Math.max(bodyGroups.length, 1));
  };
  for (let i = 0; i < 24; i++) {
    setFrame(T[0] + (T[nFrames - 1] - T[0]) * i / 23);
    const now = new THREE.Box3();
    bodyGroups.forEach((g) => now.expandByObject(g));
    if (!now.isEmpty()) {
      bounds.union(now);
      instant = Math.max(instant, now.getSize(new THREE.Vector3()).length());
    }
  }
  const extent = bounds.getSize(new THREE.Vector3());
  const horizontal = extent.clone().addScaledVector(up, -extent.dot(up));
  const follow = bodyGroups.length > 1 && instant > 0 && horizontal.length() > 4 * instant;
  const center = follow ? (setFrame(T[0]), centroid(new THREE.Vector3()))
                        : bounds.getCenter(new THREE.Vector3());
  const radius = Math.max(follow ? 0.9 * instant : 0.5 * extent.length(), 1e-3);

  // ground grid and axes
  const step = niceStep(radius / 5);
  const whole = Math.max(0.5 * extent.length(), radius);
  let gridLabel = String(Number(step.toPrecision(2)));
  // the grid: under the lowest point anything drawn reaches at any frame
  const lowest = scene.floor;
  let gridHeight = null;  // along up; null when a contact plane is the floor
  if (!floorDrawn) {
    const gridStep = niceStep(Math.max(step, whole / 100));
    const span = 2 * gridStep * Math.ceil(1.3 * whole / gridStep);
    const grid = new THREE.GridHelper(span, Math.round(span / gridStep), 0x8792a0, 0xc9d0d8);
    grid.quaternion.setFromUnitVectors(yAxis, up);
    const middle = bounds.getCenter(new THREE.Vector3());
    grid.position.copy(middle).addScaledVector(up, lowest - middle.dot(up));
    world.add(grid);
    gridHeight = grid.position.dot(up);
    gridLabel = String(Number(gridStep.toPrecision(2)));
  }
  const axisLength = 2 * step;
  world.add(new THREE.AxesHelper(axisLength));
  function label(text, position, color) {
    const canvas = document.createElement("canvas");
    canvas.width = 128; canvas.height = 128;
    const ctx = canvas.getContext("2d");
    ctx.font = "bold 96px sans-serif";
    ctx.fillStyle = color; ctx.textAlign = "center"; ctx.textBaseline = "middle";
    ctx.fillText(text, 64, 68);
    const sprite = new THREE.Sprite(new THREE.SpriteMaterial({
      map: new THREE.CanvasTexture(canvas), depthTest: false }));
    sprite.position.copy(position);
    sprite.scale.setScalar(0.35 * axisLength);
    sprite.renderOrder = 3;
    world.add(sprite);
  }
  label("x", new THREE.Vector3(1.2 * axisLength, 0, 0), "#d62728");
  label("y", new THREE.Vector3(0, 1.2 * axisLength, 0), "#2ca02c");
  label("z", new THREE.Vector3(0, 0, 1.2 * axisLength), "#1f5fd6");
  const upName = ["x", "y", "z"].map((c, i) => Math.abs(scene.up[i]) > 0.999 ?
    (scene.up[i] > 0 ? "+" : "-") + c : null).find((c) => c) || "tilted";
  parts.scale.textContent =
    `grid ${gridLabel} m; up: ${upName} (${scene.up_note})` +
    `${follow ? "; the camera follows the model" : ""}`;
  scene.notes.forEach((n) => {
    parts.notes.appendChild(document.createElement("div")).textContent = n;
  });
  parts.title.textContent = scene.title;

  // camera: look along the inertial axis across which the least motion happens
  const axes = [new THREE.Vector3(1, 0, 0), new THREE.Vector3(0, 1, 0), new THREE.Vector3(0, 0, 1)];
  const spread = [extent.x, extent.y, extent.z];
  let best = null;
  axes.forEach((ax, i) => {
    if (Math.abs(ax.dot(up)) > 0.9) return;
    if (best === null || spread[i] < spread[best]) best = i;
  });
  const side = best === null ? new THREE.Vector3(1, 0, 0) : axes[best].clone();
  side.addScaledVector(up, -side.dot(up)).normalize();
  const across = new THREE.Vector3().crossVectors(up, side).normalize();
  const el = THREE.MathUtils.degToRad(22), az = THREE.MathUtils.degToRad(28);
  const direction = side.clone().multiplyScalar(Math.cos(el) * Math.cos(az))
    .addScaledVector(across, Math.cos(el) * Math.sin(az)).addScaledVector(up, Math.sin(el));
  const distance = 0.95 * radius / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2));
  camera.position.copy(center).addScaledVector(direction, distance);
  camera.near = distance / 1000; camera.far = distance * 100;
  sun.position.copy(center).addScaledVector(direction, distance).addScaledVector(up, distance);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.copy(center);
  if (previous) {  // the same view as before the scene changed
    camera.position.copy(previous.camera.position);
    camera.near = previous.camera.near; camera.far = previous.camera.far;
    controls.target.copy(previous.controls.target);
  }
  controls.update();

  // time controls
  const slider = parts.slider;
  const playButton = parts.play;
  const speedSelect = parts.speed;
  const readout = parts.time;
  const t0 = T[0], t1 = T[nFrames - 1];
  const digits = Math.max(2, Math.min(6, 2 - Math.floor(Math.log10(Math.max(t1 - t0, 1e-9) / 100))));
  let time = t0, playing = false, last = null;
  function show(t) {
    time = Math.min(Math.max(t, t0), t1);
    setFrame(time);
    if (follow) {
      const target = centroid(new THREE.Vector3());
      camera.position.add(target.clone().sub(controls.target));
      controls.target.copy(target);
    }
    slider.value = String(Math.round(1000 * (t1 > t0 ? (time - t0) / (t1 - t0) : 0)));
    readout.textContent = `t = ${time.toFixed(digits)} s / ${t1.toFixed(digits)} s`;
  }
  slider.addEventListener("input", () => show(t0 + (t1 - t0) * Number(slider.value) / 1000),
                          { signal });
  playButton.addEventListener("click", () => {
    playing = !playing;
    playButton.textContent = playing ? "Pause" : "Play";
    if (playing && time >= t1) show(t0);
    last = null;
  }, { signal });
  function resize() {
    const w = view.clientWidth, h = view.clientHeight;
    renderer.setSize(w, h, false);
    renderer.domElement.style.width = "100%";
    renderer.domElement.style.height = "100%";
    camera.aspect = w / Math.max(h, 1);
    camera.updateProjectionMatrix();
  }
  const watcher = new ResizeObserver(resize);
  watcher.observe(view);
  resize();
  function frame(now) {
    if (playing) {
      if (last !== null) {
        let t = time + (now - last) / 1000 * Number(speedSelect.value);
        if (t > t1) t = t0 + (t - t1) % Math.max(t1 - t0, 1e-9);
        show(t);
      }
      last = now;
    }
    controls.update();
    renderer.render(world, camera);
    request = requestAnimationFrame(frame);
  }
  let request = null;
  if (previous) {
    playing = previous.playing;
    playButton.textContent = playing ? "Pause" : "Play";
    show(previous.time);
  } else show(t0);
  renderer.render(world, camera);
  request = requestAnimationFrame(frame);

  let meshes = 0;
  world.traverse((o) => { if (o.isMesh) meshes += 1; });
  const handle = {  // its getters stay getters (Object.assign would copy their values)
    meshes, t0, t1, follow, camera, controls, gridHeight, ready: true,
    setTime(t) { playing = false; playButton.textContent = "Play"; show(t);
                 renderer.render(world, camera); return time; },
    get time() { return time; },
    get playing() { return playing; },
    dispose() {  // stop drawing and listening; the elements stay for the next scene
      cancelAnimationFrame(request);
      listening.abort();
      watcher.disconnect();
      controls.dispose();
      world.traverse((o) => {
        if (o.geometry) o.geometry.dispose();
        if (o.material) [].concat(o.material).forEach((m) => { if (m.map) m.map.dispose();
                                                             m.dispose(); });
      });
      renderer.dispose();
      renderer.domElement.remove();
    },
  };
  return Object.assign(handle, counts);
}
