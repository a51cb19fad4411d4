#!/usr/bin/env python3
"""Makes the textured set of examples/shots/textured_set.toml: procedural textures (PNG) and
meshes with UVs (OBJ), written to examples/assets/set/. Python's standard library only, so it
runs anywhere; the output is committed, and tests/set_assets.rs checks it is what this script
makes.

- floorboards: planks of varied tone with a wood grain, their colour (sRGB), roughness (grain
  and wear) and normal map (grooves between planks);
- bricks: a running bond with mortar, colour and normal map (recessed mortar, bevelled edges);
- brushed: the roughness of brushed metal, fine streaks along u;
- meshes: the set's floor and back wall (UVs tiling the maps at their real size), a table, a
  block and a ball (a UV sphere).

    python3 tools/make_set_assets.py [--out examples/assets/set]
"""
import argparse
import functools
import math
import struct
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


@functools.lru_cache(maxsize=None)
def hash01(*values):
    """A uniform number in [0, 1) from integers (a 32-bit integer hash). Remembered: the noise
    asks for each lattice point many times over (the script took 15 s, 5.6 s with this, 66 MB)."""
    h = 0x9E3779B9
    for v in values:
        h ^= (v & 0xFFFFFFFF) + 0x7F4A7C15 + ((h << 6) & 0xFFFFFFFF) + (h >> 2)
        h = ((h ^ (h >> 16)) * 0x45D9F3B) & 0xFFFFFFFF
        h = ((h ^ (h >> 16)) * 0x45D9F3B) & 0xFFFFFFFF
        h ^= h >> 16
    return h / 2.0 ** 32


def value_noise(x, y, seed):
    """Smooth noise in [0, 1) over the plane (bilinear between hashed lattice values)."""
    xi, yi = math.floor(x), math.floor(y)
    fx, fy = x - xi, y - yi
    sx, sy = fx * fx * (3 - 2 * fx), fy * fy * (3 - 2 * fy)
    a, b = hash01(xi, yi, seed), hash01(xi + 1, yi, seed)
    c, d = hash01(xi, yi + 1, seed), hash01(xi + 1, yi + 1, seed)
    return (a * (1 - sx) + b * sx) * (1 - sy) + (c * (1 - sx) + d * sx) * sy


def write_png(path, width, height, pixel):
    """An 8-bit RGB PNG whose texel (x, y) (y = 0 the top row) is `pixel(x, y)` in [0, 1]^3."""
    rows = []
    for y in range(height):
        row = bytearray([0])
        for x in range(width):
            row.extend(max(0, min(255, round(c * 255))) for c in pixel(x, y))
        rows.append(bytes(row))
    chunk = lambda kind, data: (struct.pack(">I", len(data)) + kind + data
                                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    path.write_bytes(b"\x89PNG\r\n\x1a\n"
                     + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(b"".join(rows), 9)) + chunk(b"IEND", b""))


def table(f, size):
    """`f` over every texel of a `size` x `size` map, computed once: a function of (x, y)
    returning the same values."""
    rows = [[f(x, y) for x in range(size)] for y in range(size)]
    return lambda x, y: rows[y][x]


def normal_from_height(height, size, strength):
    """A normal map texel function from a height function over texels (wrapping), by central
    differences: tangent x along +u (right), y along +v (up the image)."""
    height = table(height, size)

    def pixel(x, y):
        du = height((x + 1) % size, y) - height((x - 1) % size, y)
        dv = height(x, (y - 1) % size) - height(x, (y + 1) % size)  # rows run down
        n = (-du * strength, -dv * strength, 1.0)
        length = math.sqrt(sum(c * c for c in n))
        return tuple((c / length + 1) / 2 for c in n)
    return pixel


PLANKS = 8  # across the map, along v


def plank(x, y, size):
    """The plank a texel lies on, where along it (u) and across it (v, 0 to 1), and its
    distance in texels to the nearest gap."""
    v = y / size * PLANKS
    row = int(v)
    offset = hash01(row, 7) * size
    u = ((x + offset) % size) / size
    across = v - row
    edge = min(across, 1 - across) * size / PLANKS
    end = min(u, 1 - u) * size * 2
    return row, u, across, min(edge, end)


def floorboards(out, size=512):
    def wood_at(x, y):
        row, u, across, gap = plank(x, y, size)
        base = 0.35 + 0.25 * hash01(row, 1)
        # Growth rings run along the plank, waving; fibres add a fine streak per texel row.
        wave = 4 * value_noise(u * 3, row * 3.1, 2) + 2 * value_noise(u * 11, row, 3)
        grain = math.sin(across * 26 + wave) * 0.5 + 0.5
        fibre = value_noise(u * 60, y * 0.9, 4)
        wood = base * (0.75 + 0.25 * grain + 0.1 * fibre)
        dark = 0.35 if gap < 1.5 else 1.0
        return wood * dark, grain

    # The colour and the roughness map both follow the wood's tone and grain.
    tone = table(wood_at, size)

    def colour(x, y):
        w, _ = tone(x, y)
        return (w * 1.25, w * 0.82, w * 0.5)

    def rough(x, y):
        _, grain = tone(x, y)
        wear = value_noise(x / 40, y / 40, 3)
        r = 0.3 + 0.25 * grain * wear
        return (r, r, r)

    def height(x, y):
        return min(plank(x, y, size)[3], 3.0) / 3.0

    write_png(out / "floorboards_color.png", size, size, colour)
    write_png(out / "floorboards_roughness.png", size, size, rough)
    write_png(out / "floorboards_normal.png", size, size, normal_from_height(height, size, 1.5))


ROWS, PER_ROW, MORTAR = 8, 4, 0.08


def brick(x, y, size):
    """The brick a texel lies on and its distance to the mortar (in brick heights)."""
    v = y / size * ROWS
    row = int(v)
    u = x / size * PER_ROW + (0.5 if row % 2 else 0.0)
    col = int(u)
    fv, fu = v - row, u - col
    return (row, col % PER_ROW), min(fv, 1 - fv, (min(fu, 1 - fu)) * 2)


def bricks(out, size=512):
    def colour(x, y):
        (row, col), d = brick(x, y, size)
        if d < MORTAR:
            g = 0.55 + 0.05 * value_noise(x / 6, y / 6, 5)
            return (g, g * 0.97, g * 0.92)
        k = 0.75 + 0.3 * hash01(row, col, 4) + 0.15 * value_noise(x / 10, y / 10, 6)
        return (0.55 * k, 0.22 * k, 0.14 * k)

    def height(x, y):
        _, d = brick(x, y, size)
        return 0.0 if d < MORTAR else min((d - MORTAR) / 0.05, 1.0)

    write_png(out / "bricks_color.png", size, size, colour)
    write_png(out / "bricks_normal.png", size, size, normal_from_height(height, size, 2.0))


def brushed(out, size=256):
    def rough(x, y):
        r = 0.18 + 0.2 * value_noise(x / 64, y * 1.7, 8) + 0.05 * hash01(y, 9)
        return (r, r, r)

    write_png(out / "brushed_roughness.png", size, size, rough)


def quad_obj(corners, uv_size, name):
    """One quad (corners counter-clockwise seen from its front) with UVs 0 to `uv_size`."""
    (u, v) = uv_size
    lines = [f"o {name}"] + [f"v {x:g} {y:g} {z:g}" for x, y, z in corners]
    lines += [f"vt 0 0", f"vt {u:g} 0", f"vt {u:g} {v:g}", f"vt 0 {v:g}", "f 1/1 2/2 3/3 4/4"]
    return "\n".join(lines) + "\n"


def box_obj(lo, hi, name, tiles=1.0):
    """An axis-aligned box, faces outwards, each face's UVs 0 to `tiles`."""
    c = lambda i: [(lo, hi)[(i >> k) & 1][k] for k in range(3)]
    faces = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]]
    lines = [f"o {name}"] + ["v {:g} {:g} {:g}".format(*c(i)) for i in range(8)]
    lines += [f"vt 0 0", f"vt {tiles:g} 0", f"vt {tiles:g} {tiles:g}", f"vt 0 {tiles:g}"]
    lines += [f"f {a + 1}/1 {b + 1}/2 {c_ + 1}/3 {d + 1}/4" for a, b, c_, d in faces]
    return "\n".join(lines) + "\n"


def sphere_obj(radius, rings, segments, name):
    """A UV sphere at the origin: u around (from +X towards −Z), v from the south pole up."""
    lines, uvs = [f"o {name}"], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            lines.append(f"v {radius * math.sin(theta) * math.cos(phi):.6f} "
                         f"{-radius * math.cos(theta):.6f} "
                         f"{-radius * math.sin(theta) * math.sin(phi):.6f}")
            uvs.append(f"vt {j / segments:.6f} {i / rings:.6f}")
    lines += uvs
    k = lambda i, j: i * (segments + 1) + j + 1
    for i in range(rings):
        for j in range(segments):
            a, b, c, d = k(i, j), k(i, j + 1), k(i + 1, j + 1), k(i + 1, j)
            if i > 0:
                lines.append(f"f {a}/{a} {c}/{c} {b}/{b}")
            if i < rings - 1:
                lines.append(f"f {a}/{a} {d}/{d} {c}/{c}")
    return "\n".join(lines) + "\n"


def meshes(out):
    # The floor: 8 x 8 m, the boards' map covering 2 m.
    (out / "floor.obj").write_text(quad_obj(
        [(-4, 0, 4), (4, 0, 4), (4, 0, -4), (-4, 0, -4)], (4, 4), "floor"))
    # The back wall: 8 m wide, 4 m high, a map of 8 rows of bricks over 1.2 m.
    (out / "wall.obj").write_text(quad_obj(
        [(-4, 0, -4), (4, 0, -4), (4, 4, -4), (-4, 4, -4)], (8 / 1.2, 4 / 1.2), "wall"))
    (out / "table.obj").write_text(box_obj((-0.9, 0.0, -0.5), (0.9, 0.75, 0.5), "table"))
    # The block stands on the table: its bottom face in the table's top plane.
    (out / "block.obj").write_text(box_obj((-0.15, 0.75, -0.15), (0.15, 1.05, 0.15), "block"))
    (out / "ball.obj").write_text(sphere_obj(0.35, 24, 48, "ball"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "examples" / "assets" / "set"))
    out = Path(ap.parse_args().out)
    out.mkdir(parents=True, exist_ok=True)
    floorboards(out)
    bricks(out)
    brushed(out)
    meshes(out)


if __name__ == "__main__":
    main()
