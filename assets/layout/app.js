// rift layout: the shot drawn from its camera and from a free orbit view, at any frame.
// The scene comes from the server (/api/scene?frame=F), built by the renderer itself.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const state = { ready: false, scene: null, error: null, frame: null, loads: 0 };
window.riftLayout = state;

const world = new THREE.Scene();
world.background = new THREE.Color(0x202228);
world.add(new THREE.HemisphereLight(0xffffff, 0x404040, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(3, 10, 4);
world.add(sun);
const content = new THREE.Group();
world.add(content);

function makeView(id) {
  const element = document.getElementById(id);
  // No multisampling: software WebGL (and slow GPUs) pay dearly for it.
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
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

function build(data) {
  content.clear();
  for (const o of data.objects) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.Float32BufferAttribute(o.positions, 3));
    geometry.computeVertexNormals();
    const color = new THREE.Color().setRGB(...o.color.map(c => Math.min(1, c)));
    const mesh = new THREE.Mesh(geometry,
      // Front faces only: a room's walls face inwards, so the orbit view sees into it.
      new THREE.MeshLambertMaterial({ color, side: THREE.FrontSide }));
    mesh.name = o.name;
    content.add(mesh);
  }
  for (const o of data.openings) {
    content.add(outline(o.outline, frameOf(o.here), 0x6fd3ff, false));
    content.add(outline(o.outline, frameOf(o.there), 0xffb35c, true));
  }
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
  build(data);
  state.loads += 1;
  const timeline = document.getElementById('timeline');
  timeline.min = data.frames[0];
  timeline.max = data.frames[1];
  timeline.value = data.frame;
  document.getElementById('frame').textContent = `frame ${data.frame}`;
  document.getElementById('status').textContent =
    `${data.objects.length} objects, ${data.openings.length} openings`;
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

function draw() {
  resize(orbitView, orbitCamera);
  resize(shotView, shotCamera);
  controls.update();
  if (frustum) frustum.visible = true;
  orbitView.renderer.render(world, orbitCamera);
  if (frustum) frustum.visible = false;
  // The shot camera's aspect is the film's: letterbox it in its view.
  const { clientWidth: w, clientHeight: h } = shotView.element;
  const aspect = shotCamera.aspect;
  const [vw, vh] = w / h > aspect ? [h * aspect, h] : [w, w / aspect];
  const r = shotView.renderer;
  r.setScissorTest(false);
  r.setViewport(0, 0, w, h);
  r.setClearColor(0x141518);
  r.clear();
  r.setViewport((w - vw) / 2, (h - vh) / 2, vw, vh);
  r.setScissor((w - vw) / 2, (h - vh) / 2, vw, vh);
  r.setScissorTest(true);
  r.setClearColor(0x000000);
  r.render(world, shotCamera);
  requestAnimationFrame(draw);
}

let playing = null;
document.getElementById('timeline').addEventListener('change', e => load(Number(e.target.value)));
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
