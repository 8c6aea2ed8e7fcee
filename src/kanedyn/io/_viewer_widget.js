// The notebook widget's start (after _viewer.js), an anywidget front end: kanedyn.io
// puts KD_THREE (three.js, as in the page) before _viewer.js.  The model's traits:
// scene_json (kanedyn.io.scene_data as JSON text; a new one is drawn in the same view),
// time (s; set from Python, it moves the scene there; scrubbing sets it back) and
// height (pixels).

let kdThree = null;  // three.js, loaded once for every widget of the page

function render({ model, el }) {
  const root = el.appendChild(document.createElement("div"));
  const parts = kdMarkup(root);
  let viewer = null;
  let current = null;  // the scene text drawn (or being drawn)
  const size = () => { root.style.height = model.get("height") + "px"; };
  size();
  async function draw() {
    const text = model.get("scene_json");
    if (text === current) return;
    current = text;
    try {
      kdThree = kdThree || kdLoadThree(KD_THREE);
      const { THREE, OrbitControls } = await kdThree;
      if (text !== current) return;  // a newer scene came while three.js loaded
      const scene = JSON.parse(text);
      const previous = viewer;
      if (previous) previous.dispose();
      viewer = kdBuild(THREE, OrbitControls, scene, parts, previous);
      viewer.scenes = (previous ? previous.scenes : 0) + 1;
      if (!previous) moveTo();
      el.kanedynScene = viewer;
    } catch (err) {
      kdFail(parts, err);
    }
  }
  const moveTo = () => { if (viewer) viewer.setTime(model.get("time")); };
  // scrubbing: the time reached becomes the model's while the slider moves, at
  // most once per 0.1 s (a kernel is not flooded; the viewer's own listener has
  // moved the scene by then), and when it is let go
  let lastSent = null;
  let pending = null;
  const send = () => {
    pending = null;
    if (!viewer || viewer.time === lastSent) return;
    lastSent = viewer.time;
    model.set("time", viewer.time);
    model.save_changes();
  };
  const scrubbing = () => { if (pending === null) pending = setTimeout(send, 100); };
  parts.slider.addEventListener("input", scrubbing);
  parts.slider.addEventListener("change", send);
  model.on("change:scene_json", draw);
  model.on("change:time", moveTo);
  model.on("change:height", size);
  draw();
  return () => {
    model.off("change:scene_json", draw);
    model.off("change:time", moveTo);
    model.off("change:height", size);
    if (pending !== null) clearTimeout(pending);
    if (viewer) viewer.dispose();
  };
}

export default { render };
