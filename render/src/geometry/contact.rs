//! Surfaces that touch: a glass resting on a table, its bottom face in the table's plane. A ray
//! leaving one of them starts a little off its surface ([`super::offset_origin`]), and so
//! passes the other, which lies between the surface and the new origin: light refracted out
//! through the glass's bottom would go on below the table and be lost. Contacts are found once
//! per scene, between static triangles of different objects that lie in one plane within the
//! reach of an origin's offset (where one of them lets light through: between two opaque
//! surfaces no path can go); a path leaving such a triangle first looks for the surface it
//! touches, and meets it at once if the ray leaves towards that surface's front. Touching then
//! behaves as the limit of a gap closing: the light that leaves one surface meets the other.
//!
//! A material may instead touch in optical contact (no air between, as a glass pressed onto a
//! table, or a glass sunk into it a hair): where its face touches a surface that is not, the
//! face is not there. A ray that reaches it meets the other surface at that point, and a ray
//! leaving the other surface towards it goes on beyond it, inside the glass.

use super::offset::{offset_origin, offset_reach, offset_steps};
use super::{Hit, Ray, STATIC, Triangle, intersect_watertight, triangle::ShearedRay};
use glam::Vec3;
use std::collections::HashMap;

/// Triangles whose normals are closer than this cosine count as lying in one plane.
const COPLANAR_COS: f32 = 0.95;
/// How far apart touching surfaces may lie, in offset reaches along their normal (see
/// [`offset_reach`]): beyond one reach an origin's offset no longer passes them, and rays
/// find them as any surface.
const TOLERANCE_REACHES: f32 = 2.0;

/// The contacts of a scene's static triangles: for each, the triangles of other objects it
/// touches.
#[derive(Clone, Debug, Default)]
pub struct Contacts {
    /// Per static triangle, where its partners start in `partners` (one more entry at the
    /// end); empty when no triangle touches another.
    first: Vec<u32>,
    partners: Vec<u32>,
    /// Per static triangle, true when it touches in optical contact (empty when none does).
    optical: Vec<bool>,
}

/// What a ray leaving a touching surface meets at once (see [`Contacts::meet`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Met {
    /// The touching surface, where the ray leaves.
    Surface(Hit),
    /// Nothing: the surface it faces there is in optical contact, so absent, and the ray goes
    /// on from this origin beyond that surface's plane.
    Beyond(Vec3),
}

impl Contacts {
    /// No triangle touches another.
    pub fn is_empty(&self) -> bool {
        self.partners.is_empty()
    }

    /// How many pairs of triangles touch.
    pub fn pairs(&self) -> usize {
        self.partners.len() / 2
    }

    /// True when the surface `hit` belongs to touches another object's.
    #[inline]
    pub fn touches(&self, hit: &Hit) -> bool {
        let t = hit.triangle as usize;
        hit.instance == STATIC && t + 1 < self.first.len() && self.first[t] != self.first[t + 1]
    }

    /// True when static triangle `t` touches in optical contact.
    #[inline]
    fn is_optical(&self, t: u32) -> bool {
        self.optical.get(t as usize).copied().unwrap_or(false)
    }

    /// The contacts among `triangles` (the scene's static ones, world space, with their unit
    /// normals and objects), where `transmits` says which triangles' materials let light
    /// through to their back, and `optical` which of those touch in optical contact.
    pub fn find(
        triangles: &[Triangle],
        normals: &[Vec3],
        object: &[u32],
        transmits: impl Fn(u32) -> bool,
        optical: impl Fn(u32) -> bool,
    ) -> Self {
        let clear: Vec<u32> = (0..triangles.len() as u32)
            .filter(|&t| transmits(t))
            .collect();
        if clear.is_empty() {
            return Self::default();
        }
        let grid = Grid::new(triangles, &clear);
        let mut pairs = Vec::new();
        for (b, tri) in triangles.iter().enumerate() {
            let b = b as u32;
            grid.each_near(&expanded_box(tri), |a| {
                if a != b
                    && object[a as usize] != object[b as usize]
                    && touching(triangles, normals, a, b)
                {
                    pairs.push((a.min(b), a.max(b)));
                }
            });
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut contacts = Self::from_pairs(triangles.len(), &pairs);
        if pairs.iter().any(|&(a, b)| optical(a) || optical(b)) {
            contacts.optical = (0..triangles.len() as u32).map(&optical).collect();
        }
        contacts
    }

    /// Partner lists from the pairs, each pair listed for both its triangles.
    fn from_pairs(count: usize, pairs: &[(u32, u32)]) -> Self {
        if pairs.is_empty() {
            return Self::default();
        }
        let mut degree = vec![0u32; count + 1];
        for &(a, b) in pairs {
            degree[a as usize + 1] += 1;
            degree[b as usize + 1] += 1;
        }
        let mut first = degree;
        for i in 1..first.len() {
            first[i] += first[i - 1];
        }
        let mut fill = first.clone();
        let mut partners = vec![0u32; pairs.len() * 2];
        for &(a, b) in pairs {
            for (from, to) in [(a, b), (b, a)] {
                partners[fill[from as usize] as usize] = to;
                fill[from as usize] += 1;
            }
        }
        Self {
            first,
            partners,
            optical: Vec::new(),
        }
    }

    /// What `ray` meets at once on leaving the point `p` of the static triangle `left` (its
    /// unit normals in `normals`): the nearest of the triangles `left` touches whose front
    /// faces the side the ray leaves to, and that `admits`, with its hit's distance measured
    /// from the ray's origin; or, when that one is in optical contact and `left` is not, the
    /// origin beyond it the ray goes on from.
    pub fn meet(
        &self,
        triangles: &[Triangle],
        normals: &[Vec3],
        left: u32,
        p: Vec3,
        ray: &Ray,
        admits: impl Fn(u32) -> bool,
    ) -> Option<Met> {
        let n = normals[left as usize];
        let side = if ray.dir.dot(n) > 0.0 { n } else { -n };
        let faces_side = |b: u32| normals[b as usize].dot(side) < 0.0 && admits(b);
        let (b, at, b1, b2) = self.probe(triangles, left, p, side, faces_side)?;
        if self.is_optical(b) && !self.is_optical(left) {
            return Some(Met::Beyond(offset_origin(at, side)));
        }
        Some(Met::Surface(hit_at(ray, b, at, (b1, b2))))
    }

    /// The partner of `left` nearest its plane at `p` that `accept`s, found by a probe along
    /// `side` (a unit normal of `left`) from one tolerance behind the point to one in front:
    /// the partner, the point the probe meets it at, and its barycentrics there.
    fn probe(
        &self,
        triangles: &[Triangle],
        left: u32,
        p: Vec3,
        side: Vec3,
        accept: impl Fn(u32) -> bool,
    ) -> Option<(u32, Vec3, f32, f32)> {
        let range = self.first[left as usize] as usize..self.first[left as usize + 1] as usize;
        let reach = TOLERANCE_REACHES * offset_reach(p, side);
        let start = p - side * reach;
        let probe = ShearedRay::new(start, side);
        let mut nearest: Option<(f32, (u32, Vec3, f32, f32))> = None;
        for &b in &self.partners[range] {
            if !accept(b) {
                continue;
            }
            let Some((t, b1, b2)) =
                intersect_watertight(&probe, &triangles[b as usize], 2.0 * reach)
            else {
                continue;
            };
            let off = (t - reach).abs();
            if nearest.is_none_or(|(best, _)| off < best) {
                nearest = Some((off, (b, start + side * t, b1, b2)));
            }
        }
        nearest.map(|(_, found)| found)
    }

    /// `hit`, the nearest surface a `ray` found, or the surface it touches when that one lies
    /// before it in the limit of a closing gap: two touching surfaces whose fronts face each
    /// other (a glass's bottom and the table's top) have the gap between their fronts, so a
    /// ray that reaches the front of one meets first the other, whose back faces it (a ray
    /// inside the glass meets the glass's bottom before the table). Without this a tie
    /// between the two planes is broken by chance.
    ///
    /// A surface in optical contact is not there where it touches (see
    /// [`Self::in_optical_contact`]). Only partners that `admits` count.
    pub fn first_met(
        &self,
        triangles: &[Triangle],
        normals: &[Vec3],
        hit: Hit,
        ray: &Ray,
        admits: impl Fn(u32) -> bool,
    ) -> Hit {
        if self.is_optical(hit.triangle) {
            return self.in_optical_contact(triangles, normals, hit, ray, admits);
        }
        let n = normals[hit.triangle as usize];
        let cos = ray.dir.dot(n);
        if cos >= 0.0 {
            return hit;
        }
        let p = ray.origin + ray.dir * hit.t;
        // The partner's plane may lie this far beyond `hit` along the ray.
        let slack = TOLERANCE_REACHES * offset_reach(p, n) / cos.abs().max(1e-3);
        let sheared = ShearedRay::new(ray.origin, ray.dir);
        let range = self.first[hit.triangle as usize] as usize
            ..self.first[hit.triangle as usize + 1] as usize;
        let mut first = hit;
        for &b in &self.partners[range] {
            if normals[b as usize].dot(ray.dir) <= 0.0 || self.is_optical(b) || !admits(b) {
                continue;
            }
            let Some((t, b1, b2)) =
                intersect_watertight(&sheared, &triangles[b as usize], hit.t + slack)
            else {
                continue;
            };
            if t >= hit.t - slack && (first.triangle == hit.triangle || t < first.t) {
                first = Hit {
                    t,
                    triangle: b,
                    instance: STATIC,
                    b1,
                    b2,
                };
            }
        }
        first
    }

    /// `hit`, on a surface in optical contact, or where that surface touches one that is not
    /// (and `admits`), the other surface at that point: the ray meets it from whichever side
    /// it comes (inside the glass, the table's top; from under the table, its underside).
    fn in_optical_contact(
        &self,
        triangles: &[Triangle],
        normals: &[Vec3],
        hit: Hit,
        ray: &Ray,
        admits: impl Fn(u32) -> bool,
    ) -> Hit {
        let p = ray.at(hit.t);
        let n = normals[hit.triangle as usize];
        let plain = |b: u32| !self.is_optical(b) && admits(b);
        match self.probe(triangles, hit.triangle, p, n, plain) {
            Some((b, at, b1, b2)) => hit_at(ray, b, at, (b1, b2)),
            None => hit,
        }
    }
}

/// The hit on static triangle `b` at its point `at` (barycentrics `b1`, `b2`), found by a
/// probe across the plane rather than along `ray`: its distance measured from the ray's origin.
fn hit_at(ray: &Ray, b: u32, at: Vec3, (b1, b2): (f32, f32)) -> Hit {
    Hit {
        t: (at - ray.origin).length().max(f32::MIN_POSITIVE),
        triangle: b,
        instance: STATIC,
        b1,
        b2,
    }
}

/// True when triangles `a` and `b` lie in one plane (facing either way) within the tolerance:
/// one's corners all lie that close to the other's plane, and their boxes meet.
fn touching(triangles: &[Triangle], normals: &[Vec3], a: u32, b: u32) -> bool {
    let (ta, tb) = (&triangles[a as usize], &triangles[b as usize]);
    let (na, nb) = (normals[a as usize], normals[b as usize]);
    if na.dot(nb).abs() < COPLANAR_COS || !boxes_meet(&expanded_box(ta), &expanded_box(tb)) {
        return false;
    }
    let within = |corners: &Triangle, plane: &Triangle, n: Vec3| {
        corners.v.iter().all(|&v| {
            let reach = offset_reach(v, n).max(offset_reach(plane.v[0], n));
            (v - plane.v[0]).dot(n).abs() <= TOLERANCE_REACHES * reach
        })
    };
    within(ta, tb, nb) || within(tb, ta, na)
}

/// A triangle's bounding box grown by the contact tolerance at its corners.
fn expanded_box(tri: &Triangle) -> [Vec3; 2] {
    let lo = tri.v[0].min(tri.v[1]).min(tri.v[2]);
    let hi = tri.v[0].max(tri.v[1]).max(tri.v[2]);
    let grow = TOLERANCE_REACHES * offset_steps(lo.abs().max(hi.abs()));
    [lo - grow, hi + grow]
}

fn boxes_meet(a: &[Vec3; 2], b: &[Vec3; 2]) -> bool {
    a[0].cmple(b[1]).all() && b[0].cmple(a[1]).all()
}

/// The triangles that let light through, hashed into a uniform grid of their boxes, for the
/// search for their neighbours.
struct Grid {
    cell: f32,
    cells: HashMap<[i32; 3], Vec<u32>>,
}

impl Grid {
    /// The grid of `clear` (triangle indices), its cells about the size of a typical one's
    /// box, and never so small that the largest spans more than 16 cells a side.
    fn new(triangles: &[Triangle], clear: &[u32]) -> Self {
        let boxes: Vec<[Vec3; 2]> = clear
            .iter()
            .map(|&t| expanded_box(&triangles[t as usize]))
            .collect();
        let mut sizes: Vec<f32> = boxes.iter().map(|b| (b[1] - b[0]).max_element()).collect();
        sizes.sort_unstable_by(f32::total_cmp);
        let median = sizes[sizes.len() / 2];
        let largest = sizes[sizes.len() - 1];
        let cell = median.max(largest / 16.0).max(1e-6);
        let mut grid = Self {
            cell,
            cells: HashMap::new(),
        };
        for (&t, b) in clear.iter().zip(&boxes) {
            let (lo, hi) = grid.range(b);
            for_cells(lo, hi, |c| grid.cells.entry(c).or_default().push(t));
        }
        grid
    }

    /// The cells a box spans, first and last (clamped to the range an `i32` holds).
    fn range(&self, b: &[Vec3; 2]) -> ([i32; 3], [i32; 3]) {
        let index = |x: f32| (x / self.cell).floor().clamp(-1e9, 1e9) as i32;
        (b[0].to_array().map(index), b[1].to_array().map(index))
    }

    /// Hands `visit` every triangle of the grid in a cell the box `b` spans (some more than
    /// once): cell by cell, or through the occupied cells when the box spans more than them.
    fn each_near(&self, b: &[Vec3; 2], mut visit: impl FnMut(u32)) {
        let (lo, hi) = self.range(b);
        let spanned: f64 = (0..3)
            .map(|k| (hi[k] as f64 - lo[k] as f64) + 1.0)
            .product();
        if spanned > self.cells.len() as f64 {
            let inside = |c: &[i32; 3]| (0..3).all(|k| lo[k] <= c[k] && c[k] <= hi[k]);
            for (_, list) in self.cells.iter().filter(|(c, _)| inside(c)) {
                list.iter().for_each(|&t| visit(t));
            }
        } else {
            for_cells(lo, hi, |c| {
                if let Some(list) = self.cells.get(&c) {
                    list.iter().for_each(|&t| visit(t));
                }
            });
        }
    }
}

fn for_cells(lo: [i32; 3], hi: [i32; 3], mut f: impl FnMut([i32; 3])) {
    for x in lo[0]..=hi[0] {
        for y in lo[1]..=hi[1] {
            for z in lo[2]..=hi[2] {
                f([x, y, z]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A floor (object 0, two triangles in y = `at.y`) and a unit cube of glass (object 1)
    /// standing on it, lifted by `lift`, its faces outwards.
    fn floor_and_cube(at: Vec3, lift: f32) -> (Vec<Triangle>, Vec<Vec3>, Vec<u32>) {
        let q = |x: f32, y: f32, z: f32| at + Vec3::new(x, y, z);
        let mut tris = vec![
            Triangle {
                v: [q(-2.0, 0.0, -2.0), q(-2.0, 0.0, 2.0), q(2.0, 0.0, 2.0)],
            },
            Triangle {
                v: [q(-2.0, 0.0, -2.0), q(2.0, 0.0, 2.0), q(2.0, 0.0, -2.0)],
            },
        ];
        let mut object = vec![0, 0];
        let c = |i: u32| {
            let [x, y, z] = [i & 1, (i >> 1) & 1, (i >> 2) & 1].map(|b| b as f32 - 0.5);
            q(x, y + 0.5 + lift, z)
        };
        // Each face as two triangles, wound so the normal points out of the cube.
        for [a, b, cc, d] in [
            [0, 4, 6, 2],
            [1, 3, 7, 5],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 2, 3, 1],
            [4, 5, 7, 6],
        ] {
            tris.push(Triangle {
                v: [c(a), c(b), c(cc)],
            });
            tris.push(Triangle {
                v: [c(a), c(cc), c(d)],
            });
            object.extend([1, 1]);
        }
        let normals = tris.iter().map(|t| t.normal().normalize()).collect();
        (tris, normals, object)
    }

    fn ray_from(p: Vec3, dir: Vec3) -> Ray {
        let origin = super::super::offset_origin(p, if dir.y > 0.0 { Vec3::Y } else { -Vec3::Y });
        Ray::new(origin, dir, f32::INFINITY, 0.0)
    }

    #[test]
    fn the_cubes_faces_point_out() {
        let (tris, normals, _) = floor_and_cube(Vec3::ZERO, 0.0);
        let centre = Vec3::new(0.0, 0.5, 0.0);
        for (t, n) in tris[2..].iter().zip(&normals[2..]) {
            assert!((t.v[0] - centre).dot(*n) > 0.0);
        }
    }

    /// The glass cube's bottom touches the floor wherever it stands, at the origin or 10 km
    /// from it; a cube lifted 1 mm, an opaque one, or one of the floor's own object does not.
    #[test]
    fn finds_the_faces_that_touch_and_only_those() {
        for at in [Vec3::ZERO, Vec3::new(10_000.0, 3.0, -10_000.0)] {
            let (tris, normals, object) = floor_and_cube(at, 0.0);
            let contacts = Contacts::find(
                &tris,
                &normals,
                &object,
                |t| object[t as usize] == 1,
                |_| false,
            );
            // The bottom's two triangles each meet both of the floor's.
            assert_eq!(contacts.pairs(), 4, "at {at}");
            for t in 0..tris.len() as u32 {
                let hit = Hit {
                    t: 1.0,
                    triangle: t,
                    instance: STATIC,
                    b1: 0.2,
                    b2: 0.2,
                };
                let bottom = normals[t as usize].y < -0.9;
                assert_eq!(
                    contacts.touches(&hit),
                    t < 2 || bottom,
                    "triangle {t} at {at}"
                );
            }
            let lifted = floor_and_cube(at, 1e-3);
            let apart = Contacts::find(&lifted.0, &lifted.1, &lifted.2, |t| t >= 2, |_| false);
            assert!(apart.is_empty(), "lifted 1 mm at {at}");
            let opaque = Contacts::find(&tris, &normals, &object, |_| false, |_| false);
            assert!(opaque.is_empty());
            let one = Contacts::find(&tris, &normals, &[0; 14], |t| t >= 2, |_| false);
            assert!(one.is_empty());
        }
    }

    /// Light refracted down out of the glass's bottom meets the floor; light reflected back up
    /// inside the glass does not; light leaving the floor upwards under the cube meets the
    /// glass's bottom from outside, and beside the cube meets nothing.
    #[test]
    fn a_ray_meets_the_surface_it_leaves_towards() {
        for at in [Vec3::ZERO, Vec3::new(10_000.0, 3.0, -10_000.0)] {
            let (tris, normals, object) = floor_and_cube(at, 0.0);
            let contacts = Contacts::find(
                &tris,
                &normals,
                &object,
                |t| object[t as usize] == 1,
                |_| false,
            );
            let bottom = (2..tris.len() as u32)
                .find(|&t| normals[t as usize].y < -0.9)
                .unwrap();
            let p = tris[bottom as usize].point(0.3, 0.3);
            let down = Vec3::new(0.3, -1.0, 0.1).normalize();
            let met = contacts.meet(&tris, &normals, bottom, p, &ray_from(p, down), |_| true);
            let Some(Met::Surface(met)) = met else {
                panic!("no surface met at {at}: {met:?}");
            };
            assert!(met.triangle < 2, "met {} at {at}", met.triangle);
            assert!((tris[met.triangle as usize].point(met.b1, met.b2) - p).length() < 1e-2);
            assert!(met.t > 0.0 && met.t < 1e-2, "t {}", met.t);
            let up = Vec3::new(0.3, 1.0, 0.1).normalize();
            assert!(
                contacts
                    .meet(&tris, &normals, bottom, p, &ray_from(p, up), |_| true)
                    .is_none()
            );
            assert!(
                contacts
                    .meet(&tris, &normals, bottom, p, &ray_from(p, down), |_| false)
                    .is_none()
            );
            // From the floor under the cube, up into the glass; beside it, into the air.
            let floor = (0..2).find(|&t| {
                contacts
                    .meet(&tris, &normals, t, p, &ray_from(p, up), |_| true)
                    .is_some()
            });
            let floor =
                floor.unwrap_or_else(|| panic!("the floor under the cube met nothing at {at}"));
            let met = contacts.meet(&tris, &normals, floor, p, &ray_from(p, up), |_| true);
            let Some(Met::Surface(met)) = met else {
                panic!("the floor under the cube met {met:?} at {at}");
            };
            assert!(normals[met.triangle as usize].y < -0.9);
            let beside = at + Vec3::new(1.5, 0.0, 1.5);
            for t in 0..2 {
                assert!(
                    contacts
                        .meet(&tris, &normals, t, beside, &ray_from(beside, up), |_| true)
                        .is_none()
                );
            }
        }
    }
    /// A ray inside the glass going down meets the glass's bottom before the floor in the same
    /// plane, whichever of the two the search found; a ray from above the floor beside the
    /// cube, or one coming up from under the floor, is left as it was found.
    #[test]
    fn a_ray_meets_the_surface_on_its_side_of_the_gap_first() {
        for at in [Vec3::ZERO, Vec3::new(10_000.0, 3.0, -10_000.0)] {
            let (tris, normals, object) = floor_and_cube(at, 0.0);
            let contacts = Contacts::find(
                &tris,
                &normals,
                &object,
                |t| object[t as usize] == 1,
                |_| false,
            );
            let bottom: Vec<u32> = (2..tris.len() as u32)
                .filter(|&t| normals[t as usize].y < -0.9)
                .collect();
            let origin = at + Vec3::new(0.1, 0.7, -0.2);
            let down = Vec3::new(0.05, -1.0, 0.1).normalize();
            let ray = Ray::new(origin, down, f32::INFINITY, 0.0);
            let sheared = ShearedRay::new(origin, down);
            let floor_hit = (0..2u32)
                .find_map(|t| {
                    let (d, b1, b2) = intersect_watertight(&sheared, &tris[t as usize], 10.0)?;
                    Some(Hit {
                        t: d,
                        triangle: t,
                        instance: STATIC,
                        b1,
                        b2,
                    })
                })
                .unwrap();
            let met = contacts.first_met(&tris, &normals, floor_hit, &ray, |_| true);
            assert!(
                bottom.contains(&met.triangle),
                "met {} at {at}",
                met.triangle
            );
            assert!(
                (met.t - floor_hit.t).abs() < 1e-3,
                "t {} against {}",
                met.t,
                floor_hit.t
            );
            let hidden = contacts.first_met(&tris, &normals, floor_hit, &ray, |_| false);
            assert_eq!(hidden.triangle, floor_hit.triangle);
            // The glass's own bottom, found first, stays.
            let glass_hit = Hit {
                triangle: met.triangle,
                ..met
            };
            let kept = contacts.first_met(&tris, &normals, glass_hit, &ray, |_| true);
            assert_eq!(kept.triangle, glass_hit.triangle);
            // From under the floor, up: the floor's back faces the ray, the glass's front is
            // beyond it; the search found the floor and keeps it.
            let below = at + Vec3::new(0.1, -0.5, -0.2);
            let up = Ray::new(below, Vec3::Y, f32::INFINITY, 0.0);
            let from_below = Hit {
                t: 0.5,
                triangle: floor_hit.triangle,
                ..floor_hit
            };
            let kept = contacts.first_met(&tris, &normals, from_below, &up, |_| true);
            assert_eq!(kept.triangle, floor_hit.triangle);
        }
    }

    /// In optical contact the glass's bottom is not there where it touches the floor: a ray
    /// inside the glass going down meets the floor whichever of the two planes the search
    /// found, a ray from under the floor meets its underside, and a ray leaving the floor up
    /// under the glass goes on from beyond the glass's bottom; beside the glass nothing
    /// changes.
    #[test]
    fn in_optical_contact_the_glass_bottom_is_not_there() {
        for at in [Vec3::ZERO, Vec3::new(10_000.0, 3.0, -10_000.0)] {
            let (tris, normals, object) = floor_and_cube(at, 0.0);
            let glass = |t: u32| object[t as usize] == 1;
            let contacts = Contacts::find(&tris, &normals, &object, glass, glass);
            let hit_on = |t: u32, ray: &Ray| {
                let sheared = ShearedRay::new(ray.origin, ray.dir);
                let (d, b1, b2) = intersect_watertight(&sheared, &tris[t as usize], 10.0)?;
                Some(Hit {
                    t: d,
                    triangle: t,
                    instance: STATIC,
                    b1,
                    b2,
                })
            };
            let down = Ray::new(
                at + Vec3::new(-0.1, 0.7, -0.2),
                Vec3::new(-0.05, -1.0, 0.1).normalize(),
                f32::INFINITY,
                0.0,
            );
            let bottom = (2..tris.len() as u32)
                .find(|&t| normals[t as usize].y < -0.9 && hit_on(t, &down).is_some())
                .unwrap();
            let on_bottom = hit_on(bottom, &down).unwrap();
            let on_floor = (0..2).find_map(|t| hit_on(t, &down)).unwrap();
            for found in [on_bottom, on_floor] {
                let met = contacts.first_met(&tris, &normals, found, &down, |_| true);
                assert!(met.triangle < 2, "met {} at {at}", met.triangle);
                assert!((met.t - on_floor.t).abs() < 1e-3, "t {} at {at}", met.t);
            }
            // A floor the ray's class does not see leaves the glass's bottom there.
            let hidden = contacts.first_met(&tris, &normals, on_bottom, &down, |b| b >= 2);
            assert_eq!(hidden.triangle, bottom);
            let p = down.at(on_floor.t);
            let below = Ray::new(p - 0.5 * Vec3::Y, Vec3::Y, 1.0, 0.0);
            let from_below = hit_on(bottom, &below).unwrap();
            let met = contacts.first_met(&tris, &normals, from_below, &below, |_| true);
            assert!(met.triangle < 2, "from below met {} at {at}", met.triangle);
            // Leaving the floor upwards under the glass: on, past the bottom's plane.
            let up = Vec3::new(0.3, 1.0, 0.1).normalize();
            let floor = on_floor.triangle;
            match contacts.meet(&tris, &normals, floor, p, &ray_from(p, up), |_| true) {
                Some(Met::Beyond(origin)) => {
                    assert!(
                        origin.y > p.y && origin.y - p.y < 1e-2,
                        "origin {origin} at {at}"
                    );
                    let sheared = ShearedRay::new(origin, up);
                    let again = intersect_watertight(&sheared, &tris[bottom as usize], 1.0);
                    assert!(again.is_none(), "the bottom met again at {at}");
                }
                other => panic!("leaving the floor up met {other:?} at {at}"),
            }
            let beside = at + Vec3::new(1.5, 0.0, 1.5);
            for t in 0..2 {
                assert!(
                    contacts
                        .meet(&tris, &normals, t, beside, &ray_from(beside, up), |_| true)
                        .is_none()
                );
            }
        }
    }
}
