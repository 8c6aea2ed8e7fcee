// The page's start (after _viewer.js): the scene is JSON in #kd-scene, three.js is in
// #kd-three-core, #kd-three and #kd-orbit; the viewer fills #kd-root.

const kdParts = kdMarkup(document.getElementById("kd-root"));
try {
  const text = (id) => document.getElementById(id).textContent;
  const scene = JSON.parse(text("kd-scene"));
  const { THREE, OrbitControls } = await kdLoadThree(
    { core: text("kd-three-core"), main: text("kd-three"), orbit: text("kd-orbit") });
  window.kanedynScene = kdBuild(THREE, OrbitControls, scene, kdParts);
} catch (err) {
  kdFail(kdParts, err);
}
