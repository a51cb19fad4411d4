// Editing in the orbit view: pick the camera, an object or either frame of an opening (from
// the list, or by clicking it), move or turn it with the gizmo, and everything the solver
// places from it follows live (copies, the view through openings). When a drag ends the pose
// goes to the server as an edit at the current frame (a key where the transform is keyed);
// the server checks the edited shot and answers with the scene as it now is. Keys can be set
// and deleted, a here-side copy of a there-side target added (the inverse solver), and the
// edits saved into the shot file or dropped.
import * as THREE from 'three';
import { TransformControls } from 'three/addons/controls/TransformControls.js';

// A target as the server names it, and as the page lists it.
function label(target) {
  if (target.kind === 'camera') return 'camera';
  if (target.kind === 'object') return `object ${target.name}`;
  return `opening ${target.name} (${target.side})`;
}

export class Editor {
  // `page` gives: model, world, orbitCamera, orbitElement, orbitControls, shotCamera,
  // frame() (the current frame), applied(data) (the scene after an edit), reload(),
  // showError(message), status(text), redrawn() (a promise of the next frame drawn).
  constructor(page) {
    this.page = page;
    this.target = null;
    this.pending = Promise.resolve(null);
    this.handle = new THREE.Object3D();
    page.world.add(this.handle);
    this.gizmo = new TransformControls(page.orbitCamera, page.orbitElement);
    this.gizmo.setSize(0.8);
    page.world.add(this.gizmo.getHelper());
    this.gizmo.addEventListener('dragging-changed', e => {
      page.orbitControls.enabled = !e.value;
      if (!e.value && this.target) this.commit();
    });
    this.gizmo.addEventListener('objectChange', () => this.follow());
    this.pickOnClick(page.orbitElement);
  }

  // Everything that can be edited in the scene as loaded.
  targets() {
    const { model } = this.page;
    const list = [{ kind: 'camera' }];
    for (const o of model.objects) list.push({ kind: 'object', name: o.data.name });
    for (const o of model.openings) {
      list.push({ kind: 'opening', name: o.data.name, side: 'here' });
      list.push({ kind: 'opening', name: o.data.name, side: 'there' });
    }
    return list.map(t => ({ ...t, label: label(t) }));
  }

  // The target's pose in the world now (live).
  world(target) {
    const { model, shotCamera } = this.page;
    if (target.kind === 'camera') {
      shotCamera.updateMatrixWorld();
      return shotCamera.matrixWorld.clone();
    }
    if (target.kind === 'object') return model.objects.find(o => o.data.name === target.name).world.clone();
    const o = model.openings.find(o => o.data.name === target.name);
    return (target.side === 'here' ? o.here : o.there).clone();
  }

  // Selects `target` (null: none) and puts the gizmo on it.
  select(target) {
    this.target = target ? { kind: target.kind, name: target.name, side: target.side } : null;
    if (!this.target || !this.exists(this.target)) {
      this.target = null;
      this.gizmo.detach();
      return null;
    }
    this.world(this.target).decompose(this.handle.position, this.handle.quaternion, this.handle.scale);
    this.handle.updateMatrixWorld();
    this.gizmo.attach(this.handle);
    return label(this.target);
  }

  exists(target) {
    return this.targets().some(t => label(t) === label(target));
  }

  setMode(mode) {
    this.gizmo.setMode(mode);
  }

  // Moves the target to where the handle is (live).
  follow() {
    const { model, shotCamera } = this.page;
    const t = this.target;
    this.handle.updateMatrixWorld();
    const world = this.handle.matrixWorld.clone();
    if (t.kind === 'camera') {
      shotCamera.position.copy(this.handle.position);
      shotCamera.quaternion.copy(this.handle.quaternion);
      shotCamera.updateMatrixWorld();
      this.page.cameraMoved();
    } else if (t.kind === 'object') {
      model.moveObject(model.objects.findIndex(o => o.data.name === t.name), world);
    } else {
      model.moveOpening(model.openings.findIndex(o => o.data.name === t.name), t.side, world);
    }
  }

  // Moves the selected target to `pose` ({position, rotation (x, y, z, w), scale}) as a drag
  // would, then sends the edit. Resolves with the milliseconds until the view through the
  // openings showed the move (before the server answered), and the server's answer.
  async move(pose) {
    const start = performance.now();
    this.handle.position.set(...pose.position);
    if (pose.rotation) this.handle.quaternion.set(...pose.rotation);
    if (pose.scale !== undefined) this.handle.scale.setScalar(pose.scale);
    this.follow();
    await this.page.redrawn();
    const drawMs = performance.now() - start;
    const answer = await this.commit();
    return { drawMs, answerMs: performance.now() - start, answer };
  }

  // The selected target's pose as an edit at the current frame (a key with `key`).
  poseEdit(key = false) {
    this.handle.updateMatrixWorld();
    const position = new THREE.Vector3();
    const rotation = new THREE.Quaternion();
    const scale = new THREE.Vector3();
    this.world(this.target).decompose(position, rotation, scale);
    const edit = {
      op: 'pose', target: this.serverTarget(), frame: this.page.frame(),
      position: position.toArray(), rotation: rotation.toArray(), key,
    };
    // The camera has no scale; the others keep theirs unless the gizmo changed it.
    if (this.target.kind !== 'camera') edit.scale = scale.x;
    return edit;
  }

  serverTarget() {
    const { kind, name, side } = this.target;
    return kind === 'camera' ? { kind } : kind === 'object' ? { kind, name } : { kind, name, side };
  }

  commit() {
    return this.send(this.poseEdit());
  }

  setKey() {
    return this.target ? this.send(this.poseEdit(true)) : Promise.resolve(null);
  }

  deleteKey() {
    if (!this.target) return Promise.resolve(null);
    return this.send({ op: 'delete_key', target: this.serverTarget(), frame: this.page.frame() });
  }

  // The inverse solver: a here-side copy of the selected object, back through `opening`.
  copyBack(opening) {
    if (!this.target || this.target.kind !== 'object') {
      this.page.showError('select the there-side object to copy here first');
      return Promise.resolve(null);
    }
    return this.send({ op: 'copy_back', object: this.target.name, opening, frame: this.page.frame() });
  }

  // Sends an edit; the page takes the scene the server answers with, or shows why not and
  // reloads what the server holds. Resolves with the answer (`pending` until then).
  send(edit) {
    this.pending = this.exchange(edit);
    return this.pending;
  }

  async exchange(edit) {
    const response = await fetch('/api/edit', { method: 'POST', body: JSON.stringify(edit) });
    const answer = await response.json().catch(() => ({ error: `HTTP ${response.status}` }));
    if (!response.ok || answer.error) {
      // Back to what the server holds, then why the edit was refused.
      await this.page.reload();
      this.page.showError(answer.error || `HTTP ${response.status}`);
    } else {
      this.page.showError('');
      this.page.applied(answer);
    }
    this.select(this.target);
    return answer;
  }

  async post(path) {
    const response = await fetch(path, { method: 'POST', body: '' });
    const answer = await response.json().catch(() => ({ error: `HTTP ${response.status}` }));
    this.page.showError(answer.error || '');
    return answer;
  }

  async save() {
    const answer = await this.post('/api/save');
    if (!answer.error) {
      this.page.status(`saved ${answer.saved}`);
      await this.page.reload();
    }
    return answer;
  }

  async revert() {
    const answer = await this.post('/api/revert');
    await this.page.reload();
    this.select(this.target);
    return answer;
  }

  // A click (not a drag) in the orbit view selects what it hits: an object, or an opening's
  // here or there frame.
  pickOnClick(element) {
    let down = null;
    element.addEventListener('pointerdown', e => { down = [e.clientX, e.clientY]; });
    element.addEventListener('pointerup', e => {
      if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 4 || this.gizmo.dragging) return;
      const box = element.getBoundingClientRect();
      const pointer = new THREE.Vector2(((e.clientX - box.left) / box.width) * 2 - 1,
                                        -((e.clientY - box.top) / box.height) * 2 + 1);
      const ray = new THREE.Raycaster();
      ray.setFromCamera(pointer, this.page.orbitCamera);
      const { model } = this.page;
      const candidates = [];
      for (const o of model.objects) candidates.push([o.mesh, { kind: 'object', name: o.data.name }]);
      for (const o of model.openings) {
        for (const [pick, side] of [[o.pickHere, 'here'], [o.pickThere, 'there']]) {
          pick.visible = true;
          candidates.push([pick, { kind: 'opening', name: o.data.name, side }]);
        }
      }
      const hits = ray.intersectObjects(candidates.map(c => c[0]), false);
      for (const o of model.openings) { o.pickHere.visible = false; o.pickThere.visible = false; }
      if (!hits.length) return;
      const target = candidates.find(c => c[0] === hits[0].object)[1];
      this.page.selected(target);
    });
  }
}
