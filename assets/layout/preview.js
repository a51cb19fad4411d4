// The view through openings: the world drawn from a camera, then through each opening it sees,
// level by level. An opening's outline marks the stencil where it is visible, depth is reset
// there, and the world is drawn again from the camera the constraint solver places behind the
// there frame (T·camera, with T = P_T(exit time)·P_H⁻¹(time), as the path tracer teleports),
// clipped to beyond the there plane, at the time rays have after passing it.
import * as THREE from 'three';

// A quad at the far plane over the whole viewport, for clearing where a stencil value says:
// depth to the far plane and colour to the background (black: nothing), so where the view
// through an opening meets nothing it shows nothing, not what the opening hides.
const fullScreen = (() => {
  const quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), new THREE.ShaderMaterial({
    vertexShader: 'void main() { gl_Position = vec4(position.xy, 1.0, 1.0); }',
    fragmentShader: 'void main() { gl_FragColor = vec4(0.0, 0.0, 0.0, 1.0); }',
    depthFunc: THREE.AlwaysDepth,
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

// Narrows `camera`'s projection (which fills `viewport`) to the part `box` of it, to be
// drawn with `box` as the viewport: the same image there, a smaller frustum.
function narrow(camera, viewport, box) {
  const x0 = (box.x - viewport.x) / viewport.z * 2 - 1;
  const x1 = (box.x + box.z - viewport.x) / viewport.z * 2 - 1;
  const y0 = (box.y - viewport.y) / viewport.w * 2 - 1;
  const y1 = (box.y + box.w - viewport.y) / viewport.w * 2 - 1;
  const fit = new THREE.Matrix4().makeScale(2 / (x1 - x0), 2 / (y1 - y0), 1)
    .multiply(new THREE.Matrix4().makeTranslation(-(x0 + x1) / 2, -(y0 + y1) / 2, 0));
  camera.projectionMatrix.premultiply(fit);
  camera.projectionMatrixInverse.copy(camera.projectionMatrix).invert();
}

export class Preview {
  // `world` holds `model.content`; `helpers` are drawn only at the top level (the frustum,
  // the gizmo); `depth()` is how many levels to follow.
  constructor(world, model, helpers, depth) {
    this.world = world;
    this.model = model;
    this.helpers = helpers;
    this.depth = depth;
  }

  // Draws the world from `camera` through every opening it sees, within the renderer's
  // viewport (and scissor box, where one is set).
  draw(renderer, camera) {
    const box = renderer.getViewport(new THREE.Vector4());
    if (renderer.getScissorTest()) renderer.getScissor(box);
    const scissor = renderer.getScissorTest();
    const viewport = renderer.getViewport(new THREE.Vector4());
    this.drawLevel(renderer, camera, 0, 0, this.model.time, box, viewport);
    renderer.setViewport(viewport);
    renderer.setScissor(box);
    renderer.setScissorTest(scissor);
    this.model.showMoment(this.model.time);
  }

  // The part of `box` (x, y from the bottom left, width, height; pixels) the opening's mask
  // covers as `camera` sees it: its outline's bounds on screen, or all of `box` where the
  // outline reaches behind the camera. Empty (width 0) where it is off screen.
  screenBox(mask, camera, box, v) {
    const outline = mask.geometry.attributes.position;
    const toView = new THREE.Matrix4().multiplyMatrices(camera.matrixWorldInverse, mask.matrixWorld);
    const p = new THREE.Vector3();
    const [lo, hi] = [new THREE.Vector2(Infinity, Infinity), new THREE.Vector2(-Infinity, -Infinity)];
    for (let i = 0; i < outline.count; i++) {
      p.fromBufferAttribute(outline, i).applyMatrix4(toView);
      if (p.z >= -camera.near) return box.clone();
      p.applyMatrix4(camera.projectionMatrix);
      lo.min(p);
      hi.max(p);
    }
    const x0 = Math.max(box.x, Math.floor(v.x + (lo.x + 1) / 2 * v.z));
    const y0 = Math.max(box.y, Math.floor(v.y + (lo.y + 1) / 2 * v.w));
    const x1 = Math.min(box.x + box.z, Math.ceil(v.x + (hi.x + 1) / 2 * v.z));
    const y1 = Math.min(box.y + box.w, Math.ceil(v.y + (hi.y + 1) / 2 * v.w));
    return new THREE.Vector4(x0, y0, Math.max(0, x1 - x0), Math.max(0, y1 - y0));
  }

  // Which objects camera rays see at `level`: directly at 0, through openings beyond (their
  // visibility flags); null: all (the orbit view).
  showFor(level) {
    for (const o of this.model.objects) {
      const m = o.mesh;
      m.visible = level === null || (level === 0 ? m.userData.direct : m.userData.through);
    }
  }

  stencilAll(stencil) {
    this.model.content.traverse(c => {
      if (c.material) setStencil(c.material, stencil, THREE.EqualStencilFunc, THREE.KeepStencilOp);
    });
  }

  // One level: the world from `camera` (whose projection fills `viewport`) at `time` where
  // the stencil holds `stencil`, then the openings it sees, each drawn only inside its box on
  // screen (within `box`).
  drawLevel(renderer, camera, level, stencil, time, box, viewport) {
    renderer.setViewport(viewport);
    renderer.setScissor(box);
    renderer.setScissorTest(true);
    const model = this.model;
    model.showMoment(time);
    this.stencilAll(stencil);
    this.showFor(level);
    renderer.render(this.world, camera);
    const openings = model.openings.filter(o => o.followed);
    if (level >= this.depth()) {
      for (const o of openings) {
        const limit = o.limit.children[0];
        limit.matrix.copy(model.frames(o.index, time).here);
        limit.matrixWorld.copy(limit.matrix);
        setStencil(limit.material, stencil, THREE.EqualStencilFunc, THREE.KeepStencilOp);
        renderer.render(o.limit, camera);
      }
      return;
    }
    const view = new THREE.Frustum().setFromProjectionMatrix(
      new THREE.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse));
    const eye = new THREE.Vector3().setFromMatrixPosition(camera.matrixWorld);
    for (const o of openings) {
      const here = model.frames(o.index, time).here;
      const mask = o.mask.children[0];
      mask.matrix.copy(here);
      mask.matrixWorld.copy(here);
      // Only rays into an opening's front teleport: skip it when the camera is behind its
      // plane or it lies outside the view (each skipped opening saves a whole level).
      const front = new THREE.Plane().setFromNormalAndCoplanarPoint(
        new THREE.Vector3(0, 0, 1).transformDirection(here), new THREE.Vector3().setFromMatrixPosition(here));
      if (front.distanceToPoint(eye) <= 0 || !view.intersectsObject(mask)) continue;
      const inside = this.screenBox(mask, camera, box, viewport);
      if (inside.z === 0 || inside.w === 0) continue;
      renderer.setScissor(inside);
      // Mark where the outline is visible (in front of what was drawn) at this level.
      setStencil(mask.material, stencil, THREE.EqualStencilFunc, THREE.IncrementStencilOp);
      mask.material.depthTest = true;
      renderer.render(o.mask, camera);
      // Clear inside the mark.
      setStencil(fullScreen.children[0].material, stencil + 1, THREE.EqualStencilFunc, THREE.KeepStencilOp);
      renderer.render(fullScreen, camera);
      // The teleported camera, clipped to beyond the there plane (what shows lies on its −Z
      // side), at the time rays have beyond the opening.
      const exit = model.exitTime(o.index, time);
      const there = model.frames(o.index, exit).there;
      const virtual = camera.clone();
      virtual.matrixAutoUpdate = false;
      virtual.matrixWorld.copy(there).multiply(here.clone().invert()).multiply(camera.matrixWorld);
      virtual.matrixWorldInverse.copy(virtual.matrixWorld).invert();
      const keep = new THREE.Plane().setFromNormalAndCoplanarPoint(
        new THREE.Vector3(0, 0, -1).transformDirection(there), new THREE.Vector3().setFromMatrixPosition(there));
      // A wall the there frame is set in lies behind the teleported rays' start (as their
      // origins are offset off it): a millimetre (of the frame's scale) clears it.
      keep.constant -= 1e-3 * new THREE.Vector3().setFromMatrixScale(there).x;
      const clipping = renderer.clippingPlanes;
      renderer.clippingPlanes = [keep];
      const shown = this.helpers.map(h => h.visible);
      for (const h of this.helpers) h.visible = false;
      // Its projection narrowed to the opening's box, so what lies outside the opening's
      // view is culled before it is drawn.
      narrow(virtual, viewport, inside);
      this.drawLevel(renderer, virtual, level + 1, stencil + 1, exit, inside, inside);
      renderer.setViewport(viewport);
      renderer.setScissor(inside);
      model.showMoment(time);
      this.showFor(level);
      renderer.clippingPlanes = clipping;
      this.helpers.forEach((h, i) => { h.visible = shown[i]; });
      // Put the opening's own depth back and lower the mark, so later openings at this level
      // are hidden behind it as they should be.
      setStencil(mask.material, stencil + 1, THREE.EqualStencilFunc, THREE.DecrementStencilOp);
      mask.material.depthTest = false;
      mask.material.depthWrite = true;
      renderer.render(o.mask, camera);
      mask.material.depthWrite = false;
      renderer.setScissor(box);
    }
    this.stencilAll(stencil);
  }
}
