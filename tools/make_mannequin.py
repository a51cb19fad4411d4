#!/usr/bin/env python3
"""Makes the showcase's character: a humanoid mannequin (ellipsoid limbs, torso and head over a
joint hierarchy, bound by linear blend skinning) animated running towards the back opening,
slowing to reach its left arm through the hatch (a second, small opening) for the orb on the
pillar beyond it (the IK target is the pillar's top carried back through the hatch's pair, as
`back_through` places a here-side target), then running on through the back opening carrying
it. Written as a mesh sequence of binary PLY files, one per frame, with
per-vertex velocities (units per second) so rift blurs each vertex along its path, and
per-vertex normals (each frame's, area-weighted over the faces around the vertex) so it shades
smoothly as it bends:
examples/assets/mannequin/walker.0001.ply ... walker.0025.ply (frame 25 is what frame 24's
open shutter reaches). Python's standard library only, so it runs anywhere; the output is
committed, and tests/character.rs checks it is what this script makes.

    python3 tools/make_mannequin.py [--out examples/assets/mannequin]
"""
import argparse
import math
import struct
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FPS = 24.0
FRAMES = range(1, 26)

# Where the showcase puts things (examples/shots/showcase.toml). The orb rests on the pillar
# by the left wall; a small opening, the hatch, stands upright beside the walker's path facing
# it (+x), paired with the nook in the left wall just above the orb, also facing +x. The
# walker reaches through the hatch, and the hand's copy comes out of the wall and takes the orb.
ORB_REST = (-2.7, 0.605, -2.2)
HATCH = (-0.29, 1.42, -1.75)
HATCH_NORMAL = (1.0, 0.0, 0.0)
NOOK = (-2.97, 0.85, -2.2)


def teleport_back_through_hatch(p):
    """The here-side place of `p` beyond the pair, as the constraint solver's `back_through`
    computes it: T⁻¹ = P_hatch · R_y(π) · P_nook⁻¹ (both openings turned 90° about y)."""
    quarter = rotation((0.0, 1.0, 0.0), math.pi / 2)
    local = mat_vec(transpose(quarter), sub(p, NOOK))
    turned = (-local[0], local[1], -local[2])
    return add(HATCH, mat_vec(quarter, turned))


# Joints: name, parent, rest position (metres; the mannequin stands at the origin facing +z).
JOINTS = [
    ("hips", None, (0.0, 0.95, 0.0)),
    ("spine", "hips", (0.0, 1.08, 0.0)),
    ("chest", "spine", (0.0, 1.28, 0.0)),
    ("neck", "chest", (0.0, 1.50, 0.0)),
    ("head", "neck", (0.0, 1.60, 0.0)),
]
for side, x in (("l", 1.0), ("r", -1.0)):
    JOINTS += [
        (f"{side}_shoulder", "chest", (0.19 * x, 1.45, 0.0)),
        (f"{side}_elbow", f"{side}_shoulder", (0.20 * x, 1.17, 0.0)),
        (f"{side}_wrist", f"{side}_elbow", (0.20 * x, 0.92, 0.0)),
        (f"{side}_hip", "hips", (0.10 * x, 0.92, 0.0)),
        (f"{side}_knee", f"{side}_hip", (0.10 * x, 0.51, 0.0)),
        (f"{side}_ankle", f"{side}_knee", (0.10 * x, 0.09, 0.0)),
    ]
INDEX = {name: i for i, (name, _, _) in enumerate(JOINTS)}


# --- small linear algebra: 3-vectors as tuples, rigid transforms as (3x3 rows, translation)


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def scale(a, s):
    return tuple(x * s for x in a)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a):
    return math.sqrt(dot(a, a))


def unit(a):
    n = norm(a)
    return scale(a, 1.0 / n) if n > 0 else a


def mat_mul(a, b):
    return tuple(tuple(sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)) for i in range(3))


def mat_vec(m, v):
    return tuple(dot(row, v) for row in m)


def transpose(m):
    return tuple(tuple(m[j][i] for j in range(3)) for i in range(3))


IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def rotation(axis, angle):
    """The rotation by `angle` radians about the unit `axis` (Rodrigues)."""
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return (
        (t * x * x + c, t * x * y - s * z, t * x * z + s * y),
        (t * x * y + s * z, t * y * y + c, t * y * z - s * x),
        (t * x * z - s * y, t * y * z + s * x, t * z * z + c),
    )


def euler(pitch=0.0, yaw=0.0, roll=0.0):
    """Rotations about x (pitch), then y (yaw), then z (roll), applied in that order."""
    return mat_mul(rotation((0, 0, 1), roll), mat_mul(rotation((0, 1, 0), yaw), rotation((1, 0, 0), pitch)))


def aligning(a, b):
    """The shortest rotation taking unit vector a to unit vector b."""
    axis = cross(a, b)
    s, c = norm(axis), dot(a, b)
    if s < 1e-9:
        return IDENTITY
    return rotation(scale(axis, 1.0 / s), math.atan2(s, c))


def compose(a, b):
    """Rigid transform a after b."""
    return (mat_mul(a[0], b[0]), add(mat_vec(a[0], b[1]), a[1]))


def apply(t, p):
    return add(mat_vec(t[0], p), t[1])


# --- the body


def ellipsoid(centre, radii, frame, around=14, down=10):
    """Vertices and faces (0-based) of an ellipsoid with `radii` along the columns of the
    rotation `frame` (rows), poles along its second axis."""
    vertices, faces = [], []
    top = add(centre, mat_vec(transpose(frame), (0.0, radii[1], 0.0)))
    vertices.append(top)
    for i in range(1, down):
        theta = math.pi * i / down
        for j in range(around):
            phi = 2 * math.pi * j / around
            local = (
                radii[0] * math.sin(theta) * math.cos(phi),
                radii[1] * math.cos(theta),
                radii[2] * math.sin(theta) * math.sin(phi),
            )
            vertices.append(add(centre, mat_vec(transpose(frame), local)))
    bottom = add(centre, mat_vec(transpose(frame), (0.0, -radii[1], 0.0)))
    vertices.append(bottom)
    ring = lambda i, j: 1 + (i - 1) * around + j % around
    for j in range(around):
        faces.append((0, ring(1, j + 1), ring(1, j)))
        faces.append((len(vertices) - 1, ring(down - 1, j), ring(down - 1, j + 1)))
    for i in range(1, down - 1):
        for j in range(around):
            a, b = ring(i, j), ring(i, j + 1)
            c, d = ring(i + 1, j + 1), ring(i + 1, j)
            faces.append((a, b, c))
            faces.append((a, c, d))
    return vertices, faces


def limb_frame(a, b):
    """A rotation whose second axis runs from b to a (the ellipsoid's poles along the limb)."""
    along = unit(sub(a, b))
    m = aligning((0.0, 1.0, 0.0), along)
    return transpose(m)


def joint_position(name):
    return JOINTS[INDEX[name]][2]


def segment(start, end, radius, bone, parent=None, child=None, blend=0.2):
    """An ellipsoid from joint `start` to joint `end`, bound to `bone`, blended towards
    `parent` near its start and `child` near its end (smooth elbows and knees)."""
    a, b = joint_position(start), joint_position(end)
    length = norm(sub(b, a))
    centre = scale(add(a, b), 0.5)
    radii = (radius, 0.5 * length + 0.6 * radius, radius)
    vertices, faces = ellipsoid(centre, radii, limb_frame(a, b))
    weights = []
    axis = unit(sub(b, a))
    for v in vertices:
        u = dot(sub(v, a), axis) / length
        w = {bone: 1.0}
        if parent is not None and u < blend:
            share = 0.5 * (1.0 - max(u, 0.0) / blend)
            w = {bone: 1.0 - share, parent: share}
        elif child is not None and u > 1.0 - blend:
            share = 0.5 * min((u - (1.0 - blend)) / blend, 1.0)
            w = {bone: 1.0 - share, child: share}
        weights.append(w)
    return vertices, faces, weights


def blob(centre, radii, bone):
    """An upright ellipsoid bound wholly to `bone`."""
    vertices, faces = ellipsoid(centre, radii, IDENTITY)
    return vertices, faces, [{bone: 1.0} for _ in vertices]


def body():
    """The mannequin's pieces in its rest pose: vertices, faces and skinning weights."""
    pieces = [
        blob((0.0, 0.95, 0.0), (0.16, 0.11, 0.10), "hips"),
        segment("spine", "neck", 0.125, "spine", parent="hips", child="chest", blend=0.35),
        blob((0.0, 1.36, 0.0), (0.18, 0.15, 0.105), "chest"),
        segment("neck", "head", 0.05, "neck", parent="chest"),
        blob((0.0, 1.71, 0.01), (0.088, 0.115, 0.10), "head"),
    ]
    for side in ("l", "r"):
        pieces += [
            segment(f"{side}_shoulder", f"{side}_elbow", 0.05, f"{side}_shoulder",
                    parent="chest", child=f"{side}_elbow"),
            segment(f"{side}_elbow", f"{side}_wrist", 0.042, f"{side}_elbow",
                    parent=f"{side}_shoulder"),
            blob(add(joint_position(f"{side}_wrist"), (0.0, -0.075, 0.0)),
                 (0.032, 0.075, 0.045), f"{side}_wrist"),
            segment(f"{side}_hip", f"{side}_knee", 0.075, f"{side}_hip",
                    parent="hips", child=f"{side}_knee"),
            segment(f"{side}_knee", f"{side}_ankle", 0.055, f"{side}_knee",
                    parent=f"{side}_hip"),
            blob(add(joint_position(f"{side}_ankle"), (0.0, -0.035, 0.06)),
                 (0.05, 0.04, 0.12), f"{side}_ankle"),
        ]
    vertices, faces, weights = [], [], []
    for v, f, w in pieces:
        base = len(vertices)
        vertices += v
        weights += [{INDEX[k]: x for k, x in wi.items()} for wi in w]
        faces += [tuple(base + i for i in face) for face in f]
    return vertices, faces, weights


# --- the animation

# The hips' path along z (frame, z, dz/dframe): a run that slows beside the hatch while the arm
# reaches through it (frames 9 to 14), then speeds into the back opening and through it.
WALK = [(1.0, -0.35, -0.15), (9.0, -1.55, -0.08), (14.0, -1.9, -0.06), (25.0, -4.75, -0.32)]
WALK_X = 0.2
STRIDE = 2.1  # metres per cycle of the legs

# The left hand's effector: the point 0.17 m beyond the wrist along the hand, where it holds
# the orb; upper arm and forearm-to-effector lengths for the two-bone IK.
EFFECTOR = (0.0, -0.17, 0.0)
GRAB_FRAME = 12.0


def hermite(p0, m0, p1, m1, s, span):
    s2, s3 = s * s, s * s * s
    return ((2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * span * m0
            + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * span * m1)


def walk_z(frame):
    for (f0, z0, m0), (f1, z1, m1) in zip(WALK, WALK[1:]):
        if frame <= f1 or f1 == WALK[-1][0]:
            span = f1 - f0
            return hermite(z0, m0, z1, m1, (frame - f0) / span, span)
    raise AssertionError("unreachable")


def smoothstep(a, b, x):
    t = min(max((x - a) / (b - a), 0.0), 1.0)
    return t * t * (3 - 2 * t)


def lerp(a, b, t):
    return add(scale(a, 1.0 - t), scale(b, t))


def root_at(frame):
    """The hips' placement: facing −z, bobbing with each stride."""
    z = walk_z(frame)
    stride = 2 * math.pi * (WALK[0][1] - z) / STRIDE
    y = 0.02 * math.cos(2 * stride)
    return (euler(yaw=math.pi), (WALK_X, y, z))


def reach_target(frame, shoulder):
    """Where the left hand's effector heads at `frame`: up to the hatch, in along its axis to
    the orb's place behind it (the pillar's spot carried back through the pair, as
    `back_through` places a here-side target), out again along the axis with the orb, then
    ahead of the body, carrying it."""
    normal = HATCH_NORMAL
    approach = add(HATCH, scale(normal, 0.06))
    inside = teleport_back_through_hatch(ORB_REST)
    out = add(HATCH, scale(normal, 0.12))
    aside = add(shoulder, (-0.38, -0.15, -0.3))
    carried = add(shoulder, (0.05, -0.22, -0.42))
    if frame < 9.5:
        return approach
    if frame < GRAB_FRAME:
        return lerp(approach, inside, smoothstep(9.5, GRAB_FRAME, frame))
    if frame < 14.0:
        return lerp(inside, out, smoothstep(GRAB_FRAME, 14.0, frame))
    if frame < 15.5:
        return lerp(out, aside, smoothstep(14.0, 15.5, frame))
    return lerp(aside, carried, smoothstep(15.5, 17.0, frame))


def arm_rest(side):
    """The rest directions of the upper arm and of the forearm to the effector, and their
    lengths."""
    shoulder, elbow = joint_position(f"{side}_shoulder"), joint_position(f"{side}_elbow")
    effector = add(joint_position(f"{side}_wrist"), EFFECTOR)
    upper, lower = sub(elbow, shoulder), sub(effector, elbow)
    return unit(upper), unit(lower), norm(upper), norm(lower)


def two_bone(shoulder, target, pole):
    """Directions of the upper arm and of the forearm (elbow to effector) that put the
    effector on `target` (or as near as the arm reaches), the elbow bending towards `pole`."""
    _, _, upper_arm, lower_arm = arm_rest("l")
    to = sub(target, shoulder)
    d = min(max(norm(to), abs(upper_arm - lower_arm) + 1e-4), upper_arm + lower_arm - 1e-4)
    u = unit(to)
    cos_a = (upper_arm ** 2 + d * d - lower_arm ** 2) / (2 * upper_arm * d)
    alpha = math.acos(max(-1.0, min(1.0, cos_a)))
    w = unit(sub(pole, scale(u, dot(pole, u))))
    elbow = add(shoulder, scale(add(scale(u, math.cos(alpha)), scale(w, math.sin(alpha))), upper_arm))
    return unit(sub(elbow, shoulder)), unit(sub(add(shoulder, scale(u, d)), elbow))


def local_rotations(frame, world_of):
    """Each joint's rotation relative to its rest pose (in its parent's frame), at `frame`;
    `world_of(name, rotations)` gives a joint's world transform for the reach."""
    z = walk_z(frame)
    phase = 2 * math.pi * (WALK[0][1] - z) / STRIDE
    r = {name: IDENTITY for name, _, _ in JOINTS}
    r["spine"] = euler(pitch=0.12)
    r["chest"] = euler(yaw=0.12 * math.sin(phase))
    for side, sign in (("l", 1.0), ("r", -1.0)):
        swing = sign * math.sin(phase)
        r[f"{side}_hip"] = euler(pitch=-0.65 * swing - 0.1)
        r[f"{side}_knee"] = euler(pitch=0.15 + 1.1 * max(0.0, sign * math.cos(phase)) ** 2)
        r[f"{side}_ankle"] = euler(pitch=-0.25 * swing)
        r[f"{side}_shoulder"] = euler(pitch=0.55 * swing, roll=sign * 0.12)
        r[f"{side}_elbow"] = euler(pitch=-0.9)
    # The left arm reaches through the hatch for the orb, then carries it.
    reach = smoothstep(7.0, 9.5, frame)
    if reach > 0.0:
        shoulder = apply(world_of("l_shoulder", r), joint_position("l_shoulder"))
        upper, lower = two_bone(shoulder, reach_target(frame, shoulder), (-1.0, -0.7, 0.3))
        upper_rest, lower_rest, _, _ = arm_rest("l")
        chest = world_of("chest", r)[0]
        aim_upper = aligning(upper_rest, mat_vec(transpose(chest), upper))
        aim_lower = aligning(lower_rest, mat_vec(transpose(mat_mul(chest, aim_upper)), lower))
        r["l_shoulder"] = blend_rotation(r["l_shoulder"], aim_upper, reach)
        r["l_elbow"] = blend_rotation(r["l_elbow"], aim_lower, reach)
    return r


def blend_rotation(a, b, w):
    """Rotation a turned a share w of the way to b (about the axis of a⁻¹b)."""
    d = mat_mul(transpose(a), b)
    angle = math.acos(max(-1.0, min(1.0, (d[0][0] + d[1][1] + d[2][2] - 1.0) / 2.0)))
    if angle < 1e-9:
        return a
    axis = unit((d[2][1] - d[1][2], d[0][2] - d[2][0], d[1][0] - d[0][1]))
    if norm(axis) < 1e-9:
        return b if w > 0.5 else a
    return mat_mul(a, rotation(axis, w * angle))


def pose(frame):
    """Every joint's transform at `frame` (fractional frames allowed), taking the rest pose's
    points to the world."""
    root = root_at(frame)

    def world_of(name, rotations, cache=None):
        i = INDEX[name]
        _, parent, rest = JOINTS[i]
        if parent is None:
            # About the hips' rest position, then placed by the root.
            local = (rotations[name], sub(rest, mat_vec(rotations[name], rest)))
            return compose(root, local)
        parent_world = world_of(parent, rotations)
        local = (rotations[name], sub(rest, mat_vec(rotations[name], rest)))
        return compose(parent_world, local)

    rotations = local_rotations(frame, world_of)
    return [world_of(name, rotations) for name, _, _ in JOINTS]


def skinned(vertices, weights, frame):
    """Every vertex placed by linear blend skinning at `frame`."""
    joints = pose(frame)
    out = []
    for v, w in zip(vertices, weights):
        p = (0.0, 0.0, 0.0)
        for j, share in w.items():
            p = add(p, scale(apply(joints[j], v), share))
        out.append(p)
    return out


def effector_at(frame):
    """The left hand's effector (where it holds the orb) at `frame`."""
    rest = add(joint_position("l_wrist"), EFFECTOR)
    return apply(pose(frame)[INDEX["l_wrist"]], rest)


def orb_keys():
    """The showcase orb's keys: until the grab it waits behind the hatch, where its copy through
    the hatch rests on the pillar; from then on it is in the hand."""
    def key(frame, p):
        return f"  {{ frame = {frame}, position = [{p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}], scale = 0.3 }},"

    waiting = teleport_back_through_hatch(ORB_REST)
    keys = [key(1, waiting), key(int(GRAB_FRAME), waiting)]
    keys += [key(f, effector_at(f)) for f in range(int(GRAB_FRAME) + 1, 26)]
    return "transform = { keys = [\n" + "\n".join(keys) + "\n] }"


# --- output


def vertex_normals(points, faces):
    """Each vertex's unit normal: the sum of its faces' normals, each as long as twice the
    face's area, so large faces weigh more (as modelling packages compute them)."""
    sums = [(0.0, 0.0, 0.0)] * len(points)
    for a, b, c in faces:
        n = cross(sub(points[b], points[a]), sub(points[c], points[a]))
        for i in (a, b, c):
            sums[i] = add(sums[i], n)
    return [unit(n) if norm(n) > 0.0 else (0.0, 1.0, 0.0) for n in sums]


def ply_bytes(points, velocities, faces):
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        "comment rift's mannequin (tools/make_mannequin.py); velocities in units per second\n"
        f"element vertex {len(points)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float vx\nproperty float vy\nproperty float vz\n"
        "property float nx\nproperty float ny\nproperty float nz\n"
        f"element face {len(faces)}\n"
        "property list uchar int vertex_indices\nend_header\n"
    ).encode()
    body = bytearray()
    for p, v, n in zip(points, velocities, vertex_normals(points, faces)):
        body += struct.pack("<9f", *p, *v, *n)
    for f in faces:
        body += struct.pack("<B3i", 3, *f)
    return header + bytes(body)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "examples/assets/mannequin")
    parser.add_argument("--orb-keys", action="store_true",
                        help="print the orb's transform keys for the showcase instead")
    args = parser.parse_args()
    if args.orb_keys:
        print(orb_keys())
        return
    args.out.mkdir(parents=True, exist_ok=True)
    vertices, faces, weights = body()
    h = 0.01
    for frame in FRAMES:
        points = skinned(vertices, weights, frame)
        ahead = skinned(vertices, weights, frame + h)
        behind = skinned(vertices, weights, frame - h)
        velocities = [scale(sub(a, b), FPS / (2 * h)) for a, b in zip(ahead, behind)]
        path = args.out / f"walker.{frame:04d}.ply"
        path.write_bytes(ply_bytes(points, velocities, faces))
    print(f"{len(FRAMES)} frames of {len(vertices)} vertices and {len(faces)} triangles in {args.out}")


if __name__ == "__main__":
    main()
