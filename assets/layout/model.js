// The shot as three.js objects, built from the server's scene JSON, and where everything is:
// at the frame (live, as the page edits it) and at the other moments openings with a time
// offset show (as the server placed them).
//
// Live edits follow the constraint solver: a paired opening's there frame is its partner's
// here frame turned half a turn; an object the solver carries through an opening sits at
// T·own (T⁻¹·own carried back), T = P_T·P_H⁻¹, and copies placed by the transform of another
// object move with it.
import * as THREE from 'three';

const HALF_TURN = new THREE.Matrix4().makeRotationY(Math.PI);

// A similarity {position, rotation (x, y, z, w), scale} as a matrix.
export function similarity(s) {
  return new THREE.Matrix4().compose(new THREE.Vector3(...s.position),
    new THREE.Quaternion(...s.rotation), new THREE.Vector3(s.scale, s.scale, s.scale));
}

// The colour that encodes object `index` in the ID pass (index + 1; black is nothing).
export function idColor(index) {
  const k = index + 1;
  return new THREE.Color((k & 255) / 255, ((k >> 8) & 255) / 255, 0);
}

function outline(points, color, dashed) {
  const geometry = new THREE.BufferGeometry().setFromPoints(
    points.map(([x, y]) => new THREE.Vector3(x, y, 0)));
  const material = dashed
    ? new THREE.LineDashedMaterial({ color, dashSize: 0.1, gapSize: 0.06 })
    : new THREE.LineBasicMaterial({ color });
  const line = new THREE.LineLoop(geometry, material);
  if (dashed) line.computeLineDistances();
  line.matrixAutoUpdate = false;
  return line;
}

// An instanced object's instances from the server's eight numbers each (position, quaternion
// x y z w, scale) as the instance matrices of `mesh` (a THREE.InstancedMesh).
function placeInstances(mesh, flat) {
  const m = new THREE.Matrix4();
  for (let i = 0; 8 * i < flat.length; i += 1) {
    const [x, y, z, qx, qy, qz, qw, s] = flat.slice(8 * i, 8 * i + 8);
    m.compose(new THREE.Vector3(x, y, z), new THREE.Quaternion(qx, qy, qz, qw), new THREE.Vector3(s, s, s));
    mesh.setMatrixAt(i, m);
  }
  mesh.instanceMatrix.needsUpdate = true;
  mesh.computeBoundingSphere();
}

function place(object, matrix) {
  object.matrix.copy(matrix);
  // Stand-ins outside any scene (picked, never drawn) are placed in the world directly.
  if (object.parent) object.matrixWorldNeedsUpdate = true;
  else object.matrixWorld.copy(matrix);
}

// Clips away the parts of an object inside its cull volumes, as the renderer hides them: a
// fragment is dropped when, in a volume's local frame, it lies behind (sign · −z in (0, depth])
// and within the radius of the axis.
// `toLocal` holds the volumes' world-to-local matrices, which the model updates as openings
// move.
function withCulls(material, culls, toLocal) {
  if (!culls.length) return material;
  // The shader's arrays are sized by the count: materials with different counts must not
  // share a compiled program (three.js keys programs by this callback's text otherwise).
  material.customProgramCacheKey = () => `culls:${culls.length}`;
  material.onBeforeCompile = shader => {
    shader.uniforms.cullToLocal = { value: toLocal };
    shader.uniforms.cullShape = { value: culls.map(c => new THREE.Vector3(c.sign, c.depth, c.radius)) };
    const n = culls.length;
    shader.vertexShader = shader.vertexShader
      .replace('#include <common>', '#include <common>\nvarying vec3 vCullWorld;')
      .replace('#include <project_vertex>',
               `#include <project_vertex>
#ifdef USE_INSTANCING
vCullWorld = (modelMatrix * instanceMatrix * vec4(transformed, 1.0)).xyz;
#else
vCullWorld = (modelMatrix * vec4(transformed, 1.0)).xyz;
#endif`);
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

// A ring's strands as line segments in world space.
function ringLines(ring) {
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.Float32BufferAttribute(ring.points, 3));
  const colors = [];
  for (let i = 0; i < ring.colors.length; i += 3) {
    const c = ring.colors.slice(i, i + 3);
    colors.push(...c, ...c);
  }
  geometry.setAttribute('color', new THREE.Float32BufferAttribute(colors, 3));
  const lines = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ vertexColors: true }));
  lines.matrixAutoUpdate = false;
  return lines;
}

// Moments are keyed by their time in nanoseconds (times the server sends agree to far less).
const momentKey = time => Math.round(time * 1e9);

export class Model {
  constructor(content) {
    this.content = content;
    this.objects = [];
    this.openings = [];
    this.rings = [];
    this.moments = new Map();
    this.data = null;
  }

  build(data, previewLimitColor) {
    this.content.clear();
    this.data = data;
    this.time = data.time;
    this.objects = data.objects.map((o, index) => {
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', new THREE.Float32BufferAttribute(o.positions, 3));
      geometry.computeVertexNormals();
      const color = new THREE.Color().setRGB(...o.color.map(c => Math.min(1, c)));
      // Front faces only: a room's walls face inwards, so the orbit view sees into it.
      const toLocal = o.culls.map(c => new THREE.Matrix4().fromArray(c.toLocal));
      const shaded = withCulls(new THREE.MeshLambertMaterial({ color, side: THREE.FrontSide }), o.culls, toLocal);
      const flat = withCulls(new THREE.MeshBasicMaterial({ color: idColor(index), side: THREE.DoubleSide }), o.culls, toLocal);
      // An instanced object (a USD PointInstancer's prototype): its triangles once, drawn at
      // each instance.
      const mesh = o.instances.length
        ? new THREE.InstancedMesh(geometry, shaded, o.instances.length / 8)
        : new THREE.Mesh(geometry, shaded);
      if (o.instances.length) placeInstances(mesh, o.instances);
      mesh.name = o.name;
      mesh.matrixAutoUpdate = false;
      mesh.userData = { shaded, flat, direct: o.seenByCamera, through: o.seenThroughOpenings, index };
      const world = similarity(o.placement);
      place(mesh, world);
      this.content.add(mesh);
      return { data: o, mesh, world, own: null, toLocal };
    });
    this.openings = data.openings.map((o, index) => {
      const here = similarity(o.here);
      const there = similarity(o.there);
      const hereLine = outline(o.outline, 0x6fd3ff, false);
      const thereLine = outline(o.outline, 0xffb35c, true);
      this.content.add(hereLine, thereLine);
      const shape = new THREE.Shape(o.outline.map(([x, y]) => new THREE.Vector2(x, y)));
      const geometry = new THREE.ShapeGeometry(shape);
      const mask = new THREE.Mesh(geometry,
        new THREE.MeshBasicMaterial({ colorWrite: false, depthWrite: false, side: THREE.FrontSide }));
      // What the opening shows where the preview stops following it.
      const limit = new THREE.Mesh(geometry, new THREE.MeshBasicMaterial({
        color: previewLimitColor, side: THREE.FrontSide }));
      for (const m of [mask, limit]) {
        m.matrixAutoUpdate = false;
        // An opening wins a tie with a wall it is set in, as in the path tracer.
        m.material.polygonOffset = true;
        m.material.polygonOffsetFactor = -1;
        m.material.polygonOffsetUnits = -4;
      }
      // Invisible stand-ins the orbit view picks openings' frames by.
      const pickHere = new THREE.Mesh(geometry, new THREE.MeshBasicMaterial({ side: THREE.DoubleSide }));
      const pickThere = pickHere.clone();
      for (const p of [pickHere, pickThere]) { p.matrixAutoUpdate = false; p.visible = false; }
      return {
        data: o, index, here, there, pair: o.pair, hereLine, thereLine, pickHere, pickThere,
        mask: new THREE.Scene().add(mask), limit: new THREE.Scene().add(limit),
        // Openings that teleport at most half the rays (their opacity) show what lies behind
        // them in the preview; the others are followed.
        followed: o.opacity >= 0.5, hereAtLoad: here.clone(),
      };
    });
    this.rings = data.rings.map(r => {
      const lines = ringLines(r);
      this.content.add(lines);
      return { opening: r.opening, lines };
    });
    this.moments = new Map(data.moments.map(m => [momentKey(m.time), {
      placements: m.placements.map(similarity),
      instances: m.instances,
      frames: m.openings.map(f => ({ here: similarity(f.here), there: similarity(f.there) })),
      rings: m.rings.map(r => {
        const lines = ringLines(r);
        lines.visible = false;
        this.content.add(lines);
        return lines;
      }),
    }]));
    // Each object's own transform: where the solver would place it from, given T now.
    for (const o of this.objects) o.own = this.carriedBack(o, o.world);
    this.relayout();
  }

  // T = P_T·P_H⁻¹ of opening k (live).
  teleport(k) {
    const o = this.openings[k];
    return o.there.clone().multiply(o.here.clone().invert());
  }

  // The own transform an object at `world` is placed from (T⁻¹·world through an opening,
  // T·world carried back).
  carriedBack(o, world) {
    if (o.data.through === null) return world.clone();
    const t = this.teleport(o.data.through);
    return (o.data.back ? t : t.invert()).multiply(world);
  }

  // Where the solver places an object from its own transform.
  carried(o, own) {
    if (o.data.through === null) return own.clone();
    const t = this.teleport(o.data.through);
    return (o.data.back ? t.invert() : t).multiply(own);
  }

  // Places everything from the openings' here frames and the objects' own transforms.
  relayout() {
    for (const o of this.openings) {
      if (o.pair !== null) o.there = this.openings[o.pair].here.clone().multiply(HALF_TURN);
    }
    for (const o of this.openings) {
      place(o.hereLine, o.here);
      place(o.thereLine, o.there);
      place(o.pickHere, o.here);
      place(o.pickThere, o.there);
    }
    for (const r of this.rings) {
      if (r.opening === null) continue;
      const o = this.openings[r.opening];
      place(r.lines, o.here.clone().multiply(o.hereAtLoad.clone().invert()));
    }
    for (const o of this.objects) o.world = this.carried(o, o.own);
    this.shown = undefined;
    this.showMoment(this.time);
  }

  // Moves object `index` to `world` (live): the transform that places it changes, so every
  // object placed by the same transform follows (those shown at another time through an
  // opening with a time offset follow once the server has placed them).
  moveObject(index, world) {
    const moved = this.objects[index];
    const own = this.carriedBack(moved, world);
    for (const o of this.objects) {
      const delayed = o.data.through !== null && this.openings[o.data.through].data.timeOffset !== 0;
      if (o === moved || (o.data.placedBy === moved.data.placedBy && !delayed)) o.own = own.clone();
    }
    this.relayout();
  }

  // Moves a frame of opening `k` (live); a paired there frame moves its partner's here frame.
  moveOpening(k, side, world) {
    const o = this.openings[k];
    if (side === 'here') o.here = world.clone();
    else if (o.pair !== null) this.openings[o.pair].here = world.clone().multiply(HALF_TURN);
    else o.there = world.clone();
    this.relayout();
  }

  // Opening k's frames at `time`: live at the frame's own time, else as the server placed
  // them (live when it has not).
  frames(k, time) {
    const moment = this.moments.get(momentKey(time));
    if (!moment || momentKey(time) === momentKey(this.time)) return this.openings[k];
    return moment.frames[k];
  }

  // The time a ray at `time` has after passing opening k (its offset, within the rays' times).
  exitTime(k, time) {
    const offset = this.openings[k].data.timeOffset;
    if (offset === 0) return time;
    const [t0, t1] = this.data.rayTimes;
    return Math.min(t1, Math.max(t0, time + offset));
  }

  // Puts objects and rings where they are at `time`.
  showMoment(time) {
    const key = momentKey(time);
    const moment = key === momentKey(this.time) ? null : this.moments.get(key) || null;
    if (moment === this.shown) return;
    this.shown = moment;
    this.objects.forEach((o, i) => {
      place(o.mesh, moment ? moment.placements[i] : o.world);
      if (o.data.instances.length) placeInstances(o.mesh, moment ? moment.instances[i] : o.data.instances);
      // Cull volumes sit on their opening's here (sign 1) or there (−1) frame.
      o.data.culls.forEach((c, j) => {
        const frames = moment ? moment.frames[c.opening] : this.openings[c.opening];
        o.toLocal[j].copy(c.sign > 0 ? frames.here : frames.there).invert();
      });
    });
    for (const r of this.rings) r.lines.visible = !moment;
    for (const m of this.moments.values()) for (const lines of m.rings) lines.visible = m === moment;
    this.content.updateMatrixWorld(true);
  }
}
