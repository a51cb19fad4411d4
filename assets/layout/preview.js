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

export class Preview {
  // `world` holds `model.content`; `helpers` are drawn only at the top level (the frustum,
  // the gizmo); `depth()` is how many levels to follow.
  constructor(world, model, helpers, depth) {
    this.world = world;
    this.model = model;
    this.helpers = helpers;
    this.depth = depth;
  }

  // Draws the world from `camera` through every opening it sees.
  draw(renderer, camera) {
    this.drawLevel(renderer, camera, 0, 0, this.model.time);
    this.model.showMoment(this.model.time);
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

  drawLevel(renderer, camera, level, stencil, time) {
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
      this.drawLevel(renderer, virtual, level + 1, stencil + 1, exit);
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
    }
    this.stencilAll(stencil);
  }
}
