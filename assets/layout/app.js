// rift layout: the shot drawn from its camera and from a free orbit view, at any frame.
// The scene comes from the server (/api/scene?frame=F), built by the renderer itself.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const state = { ready: false, scene: null, error: null, frame: null, loads: 0 };
window.riftLayout = state;
// How many levels of openings the preview follows at most (`?depth=N`, default 4): the shot's
// max_portal_depth when lower; the status line says which.
const PREVIEW_DEPTH = Math.max(0, Number(new URLSearchParams(location.search).get('depth') ?? 4));
// Per opening: its filled outline at the here frame (drawn into the stencil buffer) and the
// teleport T·H⁻¹ that places the camera behind the there frame.
let openings = [];
// Meshes of the objects, with their shaded and flat ID materials.
let meshes = [];

const world = new THREE.Scene();
// No scene background: three.js clears the whole target before drawing one, which would wipe
// the stencil marks and the view drawn before each opening's.
world.add(new THREE.HemisphereLight(0xffffff, 0x404040, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(3, 10, 4);
world.add(sun);
const content = new THREE.Group();
world.add(content);

function makeView(id) {
  const element = document.getElementById(id);
  // No multisampling: software WebGL (and slow GPUs) pay dearly for it.
  const renderer = new THREE.WebGLRenderer({ antialias: false, stencil: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio);
  element.appendChild(renderer.domElement);
  return { element, renderer };
}
const orbitView = makeView('orbit');
const shotView = makeView('shot');
const orbitCamera = new THREE.PerspectiveCamera(50, 1, 0.01, 10000);
orbitCamera.position.set(8, 8, 8);
const controls = new OrbitControls(orbitCamera, orbitView.renderer.domElement);
const shotCamera = new THREE.PerspectiveCamera(50, 16 / 9, 0.01, 10000);
let frustum = null;

function showError(message) {
  const box = document.getElementById('error');
  state.error = message;
  box.textContent = message;
  box.style.display = message ? 'block' : 'none';
}

function frameOf(s) {
  // An opening frame: position, quaternion (x, y, z, w) and uniform scale.
  const m = new THREE.Matrix4();
  m.compose(new THREE.Vector3(...s.position), new THREE.Quaternion(...s.rotation),
            new THREE.Vector3(s.scale, s.scale, s.scale));
  return m;
}

function outline(points, matrix, color, dashed) {
  const geometry = new THREE.BufferGeometry().setFromPoints(
    points.map(([x, y]) => new THREE.Vector3(x, y, 0)));
  const material = dashed
    ? new THREE.LineDashedMaterial({ color, dashSize: 0.1, gapSize: 0.06 })
    : new THREE.LineBasicMaterial({ color });
  const line = new THREE.LineLoop(geometry, material);
  if (dashed) line.computeLineDistances();
  line.applyMatrix4(matrix);
  return line;
}

// The colour that encodes object `index` in the ID pass (index + 1; black is nothing).
function idColor(index) {
  const k = index + 1;
  return new THREE.Color((k & 255) / 255, ((k >> 8) & 255) / 255, 0);
}

// Clips away the parts of an object inside its cull volumes, as the renderer hides them: a
// fragment is dropped when, in a volume's local frame, it lies behind (sign · −z in (0, depth])
// and within the radius of the axis.
function withCulls(material, culls) {
  if (!culls.length) return material;
  material.onBeforeCompile = shader => {
    shader.uniforms.cullToLocal = { value: culls.map(c => new THREE.Matrix4().fromArray(c.toLocal)) };
    shader.uniforms.cullShape = { value: culls.map(c => new THREE.Vector3(c.sign, c.depth, c.radius)) };
    const n = culls.length;
    shader.vertexShader = shader.vertexShader
      .replace('#include <common>', '#include <common>\nvarying vec3 vCullWorld;')
      .replace('#include <project_vertex>',
               '#include <project_vertex>\nvCullWorld = (modelMatrix * vec4(transformed, 1.0)).xyz;');
    shader.fragmentShader = shader.fragmentShader
      .replace('#include <common>', `#include <common>
varying vec3 vCullWorld;
uniform mat4 cullToLocal[${n}];
uniform vec3 cullShape[${n}];`)
      .replace('void main() {', `void main() {
  for (int i = 0; i < ${n}; i++) {
    vec3 q = (cullToLocal[i] * vec4(vCullWorld, 1.0)).xyz;
    float behind = -cullShape[i].x * q.z;
    if (behind > 0.0 && behind <= cullShape[i].y && dot(q.xy, q.xy) <= cullShape[i].z * cullShape[i].z) discard;
  }`);
  };
  return material;
}

function build(data) {
  content.clear();
  meshes = [];
  data.objects.forEach((o, index) => {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.Float32BufferAttribute(o.positions, 3));
    geometry.computeVertexNormals();
    const color = new THREE.Color().setRGB(...o.color.map(c => Math.min(1, c)));
    // Front faces only: a room's walls face inwards, so the orbit view sees into it.
    const shaded = withCulls(new THREE.MeshLambertMaterial({ color, side: THREE.FrontSide }), o.culls);
    const flat = withCulls(new THREE.MeshBasicMaterial({ color: idColor(index), side: THREE.DoubleSide }), o.culls);
    const mesh = new THREE.Mesh(geometry, shaded);
    mesh.name = o.name;
    mesh.userData = { shaded, flat, direct: o.seenByCamera, through: o.seenThroughOpenings };
    meshes.push(mesh);
    content.add(mesh);
  });
  for (const o of data.openings) {
    content.add(outline(o.outline, frameOf(o.here), 0x6fd3ff, false));
    content.add(outline(o.outline, frameOf(o.there), 0xffb35c, true));
  }
  // Openings that teleport at most half the rays (their opacity) show what lies behind them
  // in the preview; the others are followed.
  openings = data.openings.filter(o => o.opacity >= 0.5).map(o => {
    const here = frameOf(o.here);
    const there = frameOf(o.there);
    const shape = new THREE.Shape(o.outline.map(([x, y]) => new THREE.Vector2(x, y)));
    const mask = new THREE.Mesh(new THREE.ShapeGeometry(shape),
      new THREE.MeshBasicMaterial({ colorWrite: false, depthWrite: false, side: THREE.FrontSide }));
    mask.applyMatrix4(here);
    mask.updateMatrixWorld();
    // Only rays going into the front (towards the here frame's −Z) teleport; they leave
    // towards the there frame's −Z, so what shows lies on that side of the there plane.
    const teleport = there.clone().multiply(here.clone().invert());
    const normal = new THREE.Vector3(0, 0, -1).transformDirection(there);
    const origin = new THREE.Vector3().setFromMatrixPosition(there);
    const keep = new THREE.Plane().setFromNormalAndCoplanarPoint(normal, origin);
    const front = new THREE.Plane().setFromNormalAndCoplanarPoint(
      new THREE.Vector3(0, 0, 1).transformDirection(here), new THREE.Vector3().setFromMatrixPosition(here));
    // What the opening shows where the preview stops following it: nothing (black) at the
    // shot's own depth limit, as the path tracer ends such paths; dark grey where only the
    // preview's lower limit stops it.
    const limit = new THREE.Mesh(mask.geometry, new THREE.MeshBasicMaterial({
      color: PREVIEW_DEPTH >= data.maxPortalDepth ? 0x000000 : 0x303030, side: THREE.FrontSide }));
    limit.applyMatrix4(here);
    limit.updateMatrixWorld();
    return { mask: new THREE.Scene().add(mask), limit: new THREE.Scene().add(limit), teleport, keep, front };
  });
  if (data.strands.points.length) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.Float32BufferAttribute(data.strands.points, 3));
    const colors = [];
    for (let i = 0; i < data.strands.colors.length; i += 3) {
      const c = data.strands.colors.slice(i, i + 3);
      colors.push(...c, ...c);
    }
    geometry.setAttribute('color', new THREE.Float32BufferAttribute(colors, 3));
    content.add(new THREE.LineSegments(geometry,
      new THREE.LineBasicMaterial({ vertexColors: true })));
  }
  const cam = data.camera;
  shotCamera.fov = cam.fovY;
  shotCamera.aspect = cam.aspect;
  shotCamera.position.set(...cam.position);
  const basis = new THREE.Matrix4().makeBasis(new THREE.Vector3(...cam.right),
    new THREE.Vector3(...cam.up), new THREE.Vector3(...cam.back));
  shotCamera.quaternion.setFromRotationMatrix(basis);
  shotCamera.updateProjectionMatrix();
  shotCamera.updateMatrixWorld();
  if (frustum) world.remove(frustum);
  frustum = new THREE.CameraHelper(shotCamera);
  world.add(frustum);
  if (state.loads === 0) {
    // Frame the whole set in the orbit view once.
    const box = new THREE.Box3().setFromObject(content);
    box.expandByPoint(shotCamera.position);
    const centre = box.getCenter(new THREE.Vector3());
    const size = box.getSize(new THREE.Vector3()).length() || 10;
    controls.target.copy(centre);
    orbitCamera.position.copy(centre).add(new THREE.Vector3(0.6, 0.8, 0.6).multiplyScalar(size));
    orbitCamera.near = size / 1000;
    orbitCamera.far = size * 100;
    orbitCamera.updateProjectionMatrix();
  }
}

async function load(frame) {
  document.getElementById('status').textContent = 'loading…';
  const response = await fetch(frame === null ? '/api/scene' : `/api/scene?frame=${frame}`);
  const data = await response.json().catch(() => ({ error: `HTTP ${response.status}` }));
  if (!response.ok || data.error) {
    showError(data.error || `HTTP ${response.status}`);
    document.getElementById('status').textContent = '';
    state.ready = true;
    return;
  }
  showError('');
  state.scene = data;
  state.frame = data.frame;
  state.lookAt = null;
  build(data);
  state.loads += 1;
  const timeline = document.getElementById('timeline');
  timeline.min = data.frames[0];
  timeline.max = data.frames[1];
  timeline.value = data.frame;
  document.getElementById('frame').textContent = `frame ${data.frame}`;
  document.getElementById('status').textContent =
    `${data.objects.length} objects, ${data.openings.length} openings; preview through ` +
    `${Math.min(PREVIEW_DEPTH, data.maxPortalDepth)} of ${data.maxPortalDepth} opening levels`;
  state.ready = true;
}

function resize(view, camera) {
  const { clientWidth: w, clientHeight: h } = view.element;
  view.renderer.setSize(w, h, false);
  if (camera === orbitCamera) {
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  }
}

const fullScreen = (() => {
  // A quad at the far plane over the whole viewport, for resetting depth where a stencil
  // value says.
  const quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), new THREE.ShaderMaterial({
    vertexShader: 'void main() { gl_Position = vec4(position.xy, 1.0, 1.0); }',
    fragmentShader: 'void main() { gl_FragColor = vec4(0.0); }',
    colorWrite: false, depthFunc: THREE.AlwaysDepth,
  }));
  quad.frustumCulled = false;
  return new THREE.Scene().add(quad);
})();

function setStencil(material, ref, func, pass) {
  material.stencilWrite = true;
  material.stencilRef = ref;
  material.stencilFunc = func;
  material.stencilZPass = pass;
  material.stencilFail = THREE.KeepStencilOp;
  material.stencilZFail = THREE.KeepStencilOp;
}

// Draws the world from `camera`, then through each opening it sees (up to PREVIEW_DEPTH levels):
// the opening's outline marks the stencil where it is visible, depth is reset there, and the
// world is drawn again from the teleported camera, clipped to beyond the there plane.
function stencilAll(stencil) {
  content.traverse(c => {
    if (c.material) setStencil(c.material, stencil, THREE.EqualStencilFunc, THREE.KeepStencilOp);
  });
}

// Objects as camera rays see them at `level`: directly at 0, through openings beyond (their
// visibility flags); the orbit view shows them all.
function showFor(level) {
  for (const m of meshes) m.visible = level === null || (level === 0 ? m.userData.direct : m.userData.through);
}

function drawWithOpenings(renderer, camera, level = 0, stencil = 0) {
  stencilAll(stencil);
  showFor(level);
  renderer.render(world, camera);
  const limit = state.scene ? Math.min(PREVIEW_DEPTH, state.scene.maxPortalDepth) : 0;
  if (level >= limit) {
    for (const o of openings) {
      const limit = o.limit.children[0];
      setStencil(limit.material, stencil, THREE.EqualStencilFunc, THREE.KeepStencilOp);
      renderer.render(o.limit, camera);
    }
    return;
  }
  const view = new THREE.Frustum().setFromProjectionMatrix(
    new THREE.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse));
  for (const o of openings) {
    const mask = o.mask.children[0];
    // Only rays into an opening's front teleport: skip it when the camera is behind its plane
    // or it lies outside the view (each skipped opening saves a whole level of drawing).
    const eye = new THREE.Vector3().setFromMatrixPosition(camera.matrixWorld);
    if (o.front.distanceToPoint(eye) <= 0 || !view.intersectsObject(mask)) continue;
    // Mark where the outline is visible (in front of what was drawn) at this level.
    setStencil(mask.material, stencil, THREE.EqualStencilFunc, THREE.IncrementStencilOp);
    mask.material.depthTest = true;
    renderer.render(o.mask, camera);
    // Reset depth inside the mark.
    setStencil(fullScreen.children[0].material, stencil + 1, THREE.EqualStencilFunc, THREE.KeepStencilOp);
    renderer.render(fullScreen, camera);
    // The teleported camera, clipped to beyond the there plane.
    const virtual = camera.clone();
    virtual.matrixAutoUpdate = false;
    virtual.matrixWorld.copy(o.teleport).multiply(camera.matrixWorld);
    virtual.matrixWorldInverse.copy(virtual.matrixWorld).invert();
    const clipping = renderer.clippingPlanes;
    renderer.clippingPlanes = [o.keep];
    const hidden = frustum && frustum.visible;
    if (frustum) frustum.visible = false;
    drawWithOpenings(renderer, virtual, level + 1, stencil + 1);
    showFor(level);
    renderer.clippingPlanes = clipping;
    if (frustum) frustum.visible = hidden;
    // Put the opening's own depth back and lower the mark, so later openings at this level
    // are hidden behind it as they should be.
    setStencil(mask.material, stencil + 1, THREE.EqualStencilFunc, THREE.DecrementStencilOp);
    mask.material.depthTest = false;
    mask.material.depthWrite = true;
    renderer.render(o.mask, camera);
    mask.material.depthWrite = false;
  }
  stencilAll(stencil);
}

// Moves the shot camera (position and a point it looks at, world space, up +Y) as a drag in
// the page would; the pre-pass follows at the next frame drawn. Resolves with the
// milliseconds until that frame has been drawn.
state.setCamera = ({ position, lookAt }) => new Promise(done => {
  const start = performance.now();
  shotCamera.position.set(...position);
  state.lookAt = lookAt;
  shotCamera.up.set(0, 1, 0);
  shotCamera.lookAt(new THREE.Vector3(...lookAt));
  shotCamera.updateMatrixWorld();
  if (frustum) frustum.update();
  state.drawn = false;
  const wait = () => (state.drawn ? done(performance.now() - start) : requestAnimationFrame(wait));
  requestAnimationFrame(wait);
});

// Saves the shot camera's pose as the camera's key at the current frame into the shot file
// (the server keeps the file's comments and layout, and refuses a pose the shot would not
// load with). Resolves with the server's answer; a refusal shows on the page.
state.saveCamera = async () => {
  const forward = new THREE.Vector3(0, 0, -1).applyQuaternion(shotCamera.quaternion);
  const lookAt = shotCamera.position.clone().add(forward);
  const body = JSON.stringify({
    frame: state.frame,
    position: shotCamera.position.toArray(),
    look_at: state.lookAt || lookAt.toArray(),
  });
  const response = await fetch('/api/camera', { method: 'POST', body });
  const answer = await response.json().catch(() => ({ error: `HTTP ${response.status}` }));
  showError(answer.error || '');
  if (!answer.error) document.getElementById('status').textContent = `saved ${answer.saved}`;
  return answer;
};

// The check render: the path tracer's view from the camera as posed here, over the shot view,
// refined in passes of more samples (each a new render on the server). Resolves with the last
// image's size; clicking the button again hides it.
const checkImage = document.getElementById('check-image');
state.checkRender = async (passes = [1, 4, 16]) => {
  const [w, h] = state.scene.camera.resolution;
  const scale = Math.min(1, 480 / w);
  const size = [Math.max(1, Math.round(w * scale)), Math.max(1, Math.round(h * scale))];
  const forward = new THREE.Vector3(0, 0, -1).applyQuaternion(shotCamera.quaternion);
  const lookAt = state.lookAt || shotCamera.position.clone().add(forward).toArray();
  const pose = `position=${shotCamera.position.toArray().join(',')}&look_at=${lookAt.join(',')}`;
  for (const spp of passes) {
    const url = `/api/render?frame=${state.frame}&width=${size[0]}&height=${size[1]}&spp=${spp}&${pose}`;
    const response = await fetch(url);
    if (!response.ok) {
      showError(await response.text());
      return null;
    }
    const blob = await response.blob();
    checkImage.src = URL.createObjectURL(blob);
    await checkImage.decode();
    checkImage.style.display = 'block';
    document.getElementById('status').textContent = `check render: ${spp} spp`;
  }
  return [checkImage.naturalWidth, checkImage.naturalHeight];
};

// The shot camera's view as object indices (−1: nothing), `width` x `height`, rows top first:
// the ID pass the tests compare with the path tracer's Cryptomatte.
state.idPass = (width, height) => {
  const renderer = shotView.renderer;
  const target = new THREE.WebGLRenderTarget(width, height, { depthBuffer: true, stencilBuffer: true });
  for (const m of meshes) m.material = m.userData.flat;
  const hidden = content.children.filter(c => !c.isMesh && c.visible);
  for (const c of hidden) c.visible = false;
  if (frustum) frustum.visible = false;
  renderer.setRenderTarget(target);
  renderer.setScissorTest(false);
  renderer.setViewport(0, 0, width, height);
  renderer.autoClear = false;
  renderer.setClearColor(0x000000);
  renderer.clear(true, true, true);
  drawWithOpenings(renderer, shotCamera);
  const pixels = new Uint8Array(width * height * 4);
  renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
  renderer.setRenderTarget(null);
  renderer.autoClear = true;
  target.dispose();
  for (const c of hidden) c.visible = true;
  for (const m of meshes) m.material = m.userData.shaded;
  const ids = new Array(width * height);
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      const i = ((height - 1 - y) * width + x) * 4;
      ids[y * width + x] = pixels[i] + 256 * pixels[i + 1] - 1;
    }
  }
  return ids;
};

function draw() {
  resize(orbitView, orbitCamera);
  resize(shotView, shotCamera);
  controls.update();
  if (frustum) frustum.visible = true;
  showFor(null);
  orbitView.renderer.setClearColor(0x202228);
  orbitView.renderer.render(world, orbitCamera);
  if (frustum) frustum.visible = false;
  // The shot camera's aspect is the film's: letterbox it in its view.
  const { clientWidth: w, clientHeight: h } = shotView.element;
  const aspect = shotCamera.aspect;
  const [vw, vh] = w / h > aspect ? [h * aspect, h] : [w, w / aspect];
  const r = shotView.renderer;
  r.autoClear = false;
  r.setScissorTest(false);
  r.setViewport(0, 0, w, h);
  r.setClearColor(0x141518);
  r.clear(true, true, true);
  r.setViewport((w - vw) / 2, (h - vh) / 2, vw, vh);
  r.setScissor((w - vw) / 2, (h - vh) / 2, vw, vh);
  r.setScissorTest(true);
  r.setClearColor(0x000000);
  r.clear(true, true, true);
  drawWithOpenings(r, shotCamera);
  state.drawn = true;
  // The check render sits exactly over the letterboxed film.
  Object.assign(checkImage.style, {
    left: `${(w - vw) / 2}px`, top: `${(h - vh) / 2}px`, width: `${vw}px`, height: `${vh}px` });
  requestAnimationFrame(draw);
}

let playing = null;
document.getElementById('timeline').addEventListener('change', e => load(Number(e.target.value)));
document.getElementById('save').addEventListener('click', () => state.saveCamera());
document.getElementById('check').addEventListener('click', () => {
  if (checkImage.style.display === 'block') checkImage.style.display = 'none';
  else state.checkRender();
});
document.getElementById('play').addEventListener('click', () => {
  if (playing) { clearInterval(playing); playing = null; return; }
  const fps = state.scene ? state.scene.fps : 24;
  playing = setInterval(() => {
    if (!state.scene) return;
    const [first, last] = state.scene.frames;
    const next = state.frame >= last ? first : state.frame + 1;
    load(next);
  }, 1000 / fps);
});

const start = new URLSearchParams(location.search).get('frame');
load(start);
requestAnimationFrame(draw);
