// rift layout: the shot drawn from its camera and from a free orbit view, at any frame, with
// the view through every opening; edited in the orbit view (edit.js). The scene comes from
// the server (/api/scene?frame=F), built by the renderer itself.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { Model } from '/model.js';
import { Preview } from '/preview.js';
import { Editor } from '/edit.js';

const state = { ready: false, scene: null, error: null, frame: null, loads: 0 };
window.riftLayout = state;
// How many levels of openings the preview follows at most (`?depth=N`, default 4): the shot's
// max_portal_depth when lower; the status line says which.
const PREVIEW_DEPTH = Math.max(0, Number(new URLSearchParams(location.search).get('depth') ?? 4));
const previewDepth = () => (state.scene ? Math.min(PREVIEW_DEPTH, state.scene.maxPortalDepth) : 0);

const world = new THREE.Scene();
// No scene background: three.js clears the whole target before drawing one, which would wipe
// the stencil marks and the view drawn before each opening's.
world.add(new THREE.HemisphereLight(0xffffff, 0x404040, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(3, 10, 4);
world.add(sun);
const content = new THREE.Group();
world.add(content);
const model = new Model(content);

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

function status(text) {
  document.getElementById('status').textContent = text;
}

const editor = new Editor({
  model, world, orbitCamera, orbitControls: controls, shotCamera,
  orbitElement: orbitView.renderer.domElement,
  frame: () => state.frame,
  applied: data => show(data),
  reload: () => load(state.frame),
  showError, status,
  redrawn: () => nextDraw(),
  cameraMoved: () => { state.lookAt = null; if (frustum) frustum.update(); },
  selected: target => selectTarget(target),
});
const preview = new Preview(world, model, [editor.gizmo.getHelper()], previewDepth);

function build(data) {
  model.build(data, PREVIEW_DEPTH >= data.maxPortalDepth ? 0x000000 : 0x303030);
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
  preview.helpers = [editor.gizmo.getHelper(), frustum];
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
  fillTargets();
}

// Shows a scene the server sent (a frame loaded, or the shot after an edit).
function show(data) {
  state.scene = data;
  state.frame = data.frame;
  state.lookAt = null;
  // A new scene has new materials: any reveal was of the frame before.
  state.revealed = null;
  build(data);
  state.loads += 1;
  const timeline = document.getElementById('timeline');
  timeline.min = data.frames[0];
  timeline.max = data.frames[1];
  timeline.value = data.frame;
  document.getElementById('frame').textContent = `frame ${data.frame}`;
  status(`${data.objects.length} objects, ${data.openings.length} openings; preview through ` +
    `${previewDepth()} of ${data.maxPortalDepth} opening levels` +
    (data.unsaved ? '; unsaved edits' : ''));
  showKeys();
  requestDraw();
}

async function load(frame) {
  status('loading…');
  const response = await fetch(frame === null ? '/api/scene' : `/api/scene?frame=${frame}`);
  const data = await response.json().catch(() => ({ error: `HTTP ${response.status}` }));
  if (!response.ok || data.error) {
    showError(data.error || `HTTP ${response.status}`);
    status('');
    state.ready = true;
    return;
  }
  showError('');
  show(data);
  editor.select(editor.target);
  state.ready = true;
}

// The edit panel: what can be selected, and the selected target's keys.
const targetList = document.getElementById('target');
function fillTargets() {
  const chosen = targetList.value;
  targetList.replaceChildren(new Option('(select to edit)', ''),
    ...editor.targets().map(t => new Option(t.label, JSON.stringify(t))));
  targetList.value = [...targetList.options].some(o => o.value === chosen) ? chosen : '';
  const openings = document.getElementById('copy-through');
  openings.replaceChildren(...model.openings.map(o => new Option(o.data.name, o.data.name)));
}

function selectTarget(target) {
  const chosen = editor.select(target);
  const option = [...targetList.options].find(o => o.value && JSON.parse(o.value).label === chosen);
  targetList.value = option ? option.value : '';
  showKeys();
  return chosen;
}

function showKeys() {
  const t = editor.target;
  const data = state.scene;
  let keys = null;
  if (t && data) {
    if (t.kind === 'camera') keys = data.camera.keys;
    else if (t.kind === 'object') keys = data.objects.find(o => o.name === t.name)?.keys;
    else {
      const o = data.openings.find(o => o.name === t.name);
      keys = o && (t.side === 'here' ? o.hereKeys : o.thereKeys);
    }
  }
  document.getElementById('keys').textContent =
    !t ? '' : keys ? `keys: ${keys.join(', ')}` : 'not keyed';
}

function resize(view, camera) {
  const { clientWidth: w, clientHeight: h } = view.element;
  view.renderer.setSize(w, h, false);
  if (camera === orbitCamera) {
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  }
}

// Views are drawn when something changed (a scene shown, the orbit camera moved, the page
// used, an edit), never in a loop: an open page that nobody touches costs no processor time.
let drawPending = false;
function requestDraw() {
  if (drawPending) return;
  drawPending = true;
  requestAnimationFrame(draw);
}
// Waiting for the next frame drawn (asking for one).
let drawnWaiters = [];
const nextDraw = () => {
  const drawn = new Promise(done => drawnWaiters.push(done));
  requestDraw();
  return drawn;
};
state.redraw = () => nextDraw();

// Moves the shot camera (position and a point it looks at, world space, up +Y) as a drag in
// the page would; the pre-pass follows at the next frame drawn. Resolves with the
// milliseconds until that frame has been drawn.
state.setCamera = async ({ position, lookAt }) => {
  const start = performance.now();
  shotCamera.position.set(...position);
  shotCamera.up.set(0, 1, 0);
  shotCamera.lookAt(new THREE.Vector3(...lookAt));
  shotCamera.updateMatrixWorld();
  state.lookAt = lookAt;
  if (frustum) frustum.update();
  await nextDraw();
  return performance.now() - start;
};

// Saves the shot camera's pose as the camera's key at the current frame (a point it looks at
// where setCamera gave one), then the shot file. Resolves with the server's answer; a refusal
// shows on the page.
state.saveCamera = async () => {
  editor.select({ kind: 'camera' });
  const edit = editor.poseEdit();
  if (state.lookAt) {
    delete edit.rotation;
    edit.look_at = state.lookAt;
  }
  const answer = await editor.send(edit);
  return answer.error ? answer : editor.save();
};

// The editing API the buttons use (and the tests).
state.targets = () => editor.targets();
state.select = target => selectTarget(target);
state.move = pose => editor.move(pose);
state.setKey = () => editor.setKey();
state.deleteKey = () => editor.deleteKey();
state.copyBack = opening => editor.copyBack(opening);
state.save = () => editor.save();
state.revert = () => editor.revert();
// Resolves once the last edit sent has been answered, with that answer.
state.idle = () => editor.pending;
// Where the gizmo's centre is on the page (pixels), for dragging it.
state.gizmoOnScreen = () => {
  const p = editor.handle.getWorldPosition(new THREE.Vector3()).project(orbitCamera);
  const box = orbitView.renderer.domElement.getBoundingClientRect();
  return [box.left + (p.x + 1) / 2 * box.width, box.top + (1 - p.y) / 2 * box.height];
};
// Where an object is now (live), as a column-major matrix.
state.placement = name => model.objects.find(o => o.data.name === name)?.world.toArray();

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
    // The server says whether it denoised: "fast", "off", or "unavailable: why".
    const denoised = response.headers.get('x-rift-denoised') || 'off';
    status(`check render: ${spp} spp, ${denoised === 'fast' ? 'denoised' : `not denoised (${denoised})`}`);
  }
  return [checkImage.naturalWidth, checkImage.naturalHeight];
};

// What the openings reveal at this frame (the server's `rift reveal` of it): every object an
// opening shows is tinted in both views, those the camera sees only through openings (which
// set dressers and lighters must dress) strongest, and named in the status line. Resolves with
// the rows; `clearReveal` takes the tints off.
const REVEAL_TINT = { only: 0xff7a1a, also: 0x2a4f80 };
state.revealed = null;
state.reveal = async () => {
  const response = await fetch(`/api/reveal?frame=${state.frame}`);
  const data = await response.json().catch(() => ({ error: `HTTP ${response.status}` }));
  if (!response.ok || data.error) {
    showError(data.error || `HTTP ${response.status}`);
    return null;
  }
  const only = new Set(data.seen.filter(r => r.only_through_openings).map(r => r.object));
  const also = new Set(data.seen.filter(r => !r.only_through_openings).map(r => r.object));
  for (const o of model.objects) {
    const name = o.data.name;
    const tint = only.has(name) ? REVEAL_TINT.only : also.has(name) ? REVEAL_TINT.also : 0;
    o.mesh.userData.shaded.emissive.setHex(tint);
  }
  state.revealed = data;
  status(`frame ${state.frame}: the openings show ${only.size + also.size} objects; ` +
    `only through them (dress these): ${[...only].join(', ') || 'none'}`);
  return data.seen;
};
state.clearReveal = () => {
  for (const o of model.objects) o.mesh.userData.shaded.emissive.setHex(0);
  state.revealed = null;
  status('');
};
// The objects tinted now, with their tint (as hex).
state.highlighted = () => model.objects
  .filter(o => o.mesh.userData.shaded.emissive.getHex() !== 0)
  .map(o => ({ name: o.data.name, tint: o.mesh.userData.shaded.emissive.getHexString() }));

// The shot camera's view as object indices (−1: nothing), `width` x `height`, rows top first:
// the ID pass the tests compare with the path tracer's Cryptomatte.
state.idPass = (width, height) => {
  const renderer = shotView.renderer;
  const target = new THREE.WebGLRenderTarget(width, height, { depthBuffer: true, stencilBuffer: true });
  for (const o of model.objects) o.mesh.material = o.mesh.userData.flat;
  const hidden = world.children.concat(content.children).filter(c => !c.isMesh && !c.isLight && c !== content && c.visible);
  for (const c of hidden) c.visible = false;
  renderer.setRenderTarget(target);
  renderer.setScissorTest(false);
  renderer.setViewport(0, 0, width, height);
  renderer.autoClear = false;
  renderer.setClearColor(0x000000);
  renderer.clear(true, true, true);
  preview.draw(renderer, shotCamera);
  const pixels = new Uint8Array(width * height * 4);
  renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
  renderer.setRenderTarget(null);
  renderer.autoClear = true;
  target.dispose();
  for (const c of hidden) c.visible = true;
  for (const o of model.objects) o.mesh.material = o.mesh.userData.shaded;
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
  drawPending = false;
  resize(orbitView, orbitCamera);
  resize(shotView, shotCamera);
  controls.update();
  if (frustum) frustum.visible = true;
  preview.showFor(null);
  orbitView.renderer.setClearColor(0x202228);
  orbitView.renderer.render(world, orbitCamera);
  // The shot view: no frustum or gizmo, the shot camera's aspect (the film's) letterboxed.
  const helpers = preview.helpers.map(h => h.visible);
  for (const h of preview.helpers) h.visible = false;
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
  preview.draw(r, shotCamera);
  preview.helpers.forEach((x, i) => { x.visible = helpers[i]; });
  state.drawn = true;
  const waiting = drawnWaiters;
  drawnWaiters = [];
  for (const done of waiting) done();
  // The check render sits exactly over the letterboxed film.
  Object.assign(checkImage.style, {
    left: `${(w - vw) / 2}px`, top: `${(h - vh) / 2}px`, width: `${vw}px`, height: `${vh}px` });
}

// What changes the views: the orbit controls, the window's size, anything done with the
// pointer or the keyboard, and every call of the page's API (the buttons' and the tests'),
// once it is made and again once it has finished.
controls.addEventListener('change', requestDraw);
for (const kind of ['resize', 'pointerdown', 'pointermove', 'pointerup', 'wheel', 'keydown']) {
  window.addEventListener(kind, requestDraw);
}
for (const [name, f] of Object.entries(state)) {
  if (typeof f !== 'function' || name === 'redraw') continue;
  state[name] = (...args) => {
    requestDraw();
    const result = f(...args);
    Promise.resolve(result).then(requestDraw, requestDraw);
    return result;
  };
}

let playing = null;
const button = (id, action) => document.getElementById(id).addEventListener('click', action);
document.getElementById('timeline').addEventListener('change', e => load(Number(e.target.value)));
targetList.addEventListener('change', () => {
  selectTarget(targetList.value ? JSON.parse(targetList.value) : null);
});
button('move', () => editor.setMode('translate'));
button('turn', () => editor.setMode('rotate'));
button('set-key', () => editor.setKey());
button('delete-key', () => editor.deleteKey());
button('copy-here', () => editor.copyBack(document.getElementById('copy-through').value));
button('save', () => editor.save());
button('revert', () => editor.revert());
button('check', () => {
  if (checkImage.style.display === 'block') checkImage.style.display = 'none';
  else state.checkRender();
});
button('reveal', () => (state.revealed ? state.clearReveal() : state.reveal()));
button('play', () => {
  if (playing) { clearInterval(playing); playing = null; return; }
  const fps = state.scene ? state.scene.fps : 24;
  playing = setInterval(() => {
    if (!state.scene) return;
    const [first, last] = state.scene.frames;
    load(state.frame >= last ? first : state.frame + 1);
  }, 1000 / fps);
});
window.addEventListener('keydown', e => {
  if (e.target.tagName === 'INPUT' || e.target.tagName === 'SELECT') return;
  if (e.key === 'w') editor.setMode('translate');
  if (e.key === 'e') editor.setMode('rotate');
  if (e.key === 'Escape') selectTarget(null);
});

const start = new URLSearchParams(location.search).get('frame');
load(start);
requestDraw();
