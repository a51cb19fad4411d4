//! Queries over obvhs' compressed wide BVH (eight children a node, each child's box quantized
//! to bytes on the node's power-of-two grid; Ylitie et al. 2017). obvhs builds the trees and
//! fixes their layout; the traversal is ours, for three reasons:
//!
//! - the library's node test never accepts a child box nearer than t = 1e-4, which dropped
//!   whatever lies within 0.1 mm of a ray's origin (light leaked into narrower crevices);
//! - it takes a direction component's side from `d < 0` but its inverse's sign from the sign
//!   bit, so a −0.0 component (a ray exactly along −Z, say) missed flat boxes;
//! - it widens the quantized planes to floats one lane at a time. Here all eight children are
//!   tested as one vector operation (AVX2 when the processor has it, chosen once per query).
//!
//! Any-hit queries, and closest-hit queries of triangle trees, visit children in the order of
//! the ray's octant, as the layout intends; [`closest_hit`] (strands, instances) visits them
//! nearest entry first. A closest-hit query shrinks its range as hits are found, an any-hit
//! query stops at the first.

use crate::platform::prefetch::prefetch;
use glam::Vec3;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::CwBvhNode;
use std::mem::MaybeUninit;
use std::ops::RangeInclusive;

/// Direction components are kept at least this far from zero, so inverses stay finite and a
/// quantized plane at 0 never makes 0 × ∞; at 1e-18 a box 1e12 m across is still exact.
const MIN_COMPONENT: f32 = 1e-18;

/// Groups of children waiting that fit on the traversal's fixed stack: one a level, and a
/// balanced wide BVH over 2^32 primitives is about eleven levels deep. Deeper (lopsided) trees
/// spill onto the heap.
const STACK: usize = 32;

/// Trees whose queries read at least this many bytes at random (32Ki nodes of 80 bytes: 2.5
/// MiB, beyond a core's L2) have their next nodes and leaves fetched ahead; smaller ones stay
/// in cache, and fetching ahead only costs them (6% on the Cornell box).
const LARGE_TREE_BYTES: usize = 32 * 1024 * std::mem::size_of::<CwBvhNode>();

/// Whether queries that read `bytes` at random (the nodes of one tree, or of every tree a ray
/// may pick from, such as a moving ring's time slices, and what their leaves read) should
/// fetch nodes and leaves ahead.
pub fn worth_fetching_ahead(bytes: usize) -> bool {
    bytes >= LARGE_TREE_BYTES
}

/// The bytes of `bvh`'s nodes.
pub fn node_bytes(bvh: &CwBvh) -> usize {
    std::mem::size_of_val(bvh.nodes.as_slice())
}

/// The bits of a node group that name inner children (the rest name primitives).
const INNER_BITS: u32 = 0xff00_0000;

/// A ray as the node tests read it.
#[derive(Clone, Copy, Debug)]
pub struct BoxRay {
    origin: Vec3,
    /// Per axis, 1 / the direction component (kept finite).
    inv_dir: Vec3,
    /// Per axis, whether the direction points down it (−0.0 counts as up, as for `inv_dir`).
    down: [bool; 3],
    /// The octant's visiting order in the layout's encoding: the three "points up" bits.
    octant_order: u32,
}

impl BoxRay {
    /// The ray `origin + t·dir` (any length of `dir`; distances are in its units).
    #[inline]
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        let down = [dir.x < 0.0, dir.y < 0.0, dir.z < 0.0];
        // Signs by selection rather than per-axis branches: a ray's axis signs are coin flips
        // to the branch predictor. (glam selects a `Vec3` lane by lane, and one lane still
        // compiles to a branch; vector selects in `Vec3A` lanes measured no faster, see
        // docs/performance.md.)
        let inverse = Vec3::ONE / dir.abs().max(Vec3::splat(MIN_COMPONENT));
        Self {
            origin,
            inv_dir: Vec3::select(dir.cmplt(Vec3::ZERO), -inverse, inverse),
            down,
            octant_order: (!down[0] as u32) << 2 | (!down[1] as u32) << 1 | !down[2] as u32,
        }
    }

    /// The entry distance of the box `min`..`max` in [0, `t_max`], or `None` when the ray
    /// misses it there.
    #[inline]
    pub fn enters(&self, min: Vec3, max: Vec3, t_max: f32) -> Option<f32> {
        let a = (min - self.origin) * self.inv_dir;
        let b = (max - self.origin) * self.inv_dir;
        let near = a.min(b).max_element().max(0.0);
        let far = a.max(b).min_element().min(t_max);
        (near <= far).then_some(near)
    }
}

/// The test a traversal runs on each primitive it reaches. Hot queries implement it on a type
/// whose `test` is `#[inline(always)]`, so it lands inside the traversal loop: a closure there
/// is inlined or not as the compiler's budget falls, which moved the Cornell box by 4%.
pub trait LeafTest {
    /// Tests the primitive at `slot` (an index into `bvh.primitive_indices`) against the range
    /// [0, `range`], shrinking it to a nearer hit (closest-hit queries); true stops the
    /// traversal (any-hit queries).
    fn test(&mut self, slot: usize, range: &mut f32) -> bool;
}

/// Runs `test` on the primitives of `bvh` along `ray` for t in [0, `range`], in the layout's
/// octant order, until it asks to stop (true) or none is left (false). `leaves` is what the
/// test reads, by slot (empty if nothing such), fetched ahead with the nodes when
/// `fetch_ahead` (see [`worth_fetching_ahead`]).
///
/// It is compiled as its caller is: for AVX2 when `AVX2`, else for the baseline. A caller
/// compiled twice (see [`crate::platform::cpu`]) takes its ray set-up and leaf tests into the same
/// compilation; a call from baseline code into the AVX2 traversal cannot be inlined, and
/// crossing cost about 75 instructions a query on a Cornell box.
///
/// # Safety
/// `AVX2` only in code compiled for AVX2, POPCNT, LZCNT and BMI1 (so on a processor that has
/// them: [`crate::platform::cpu::has_avx2_set`]).
#[inline(always)]
pub unsafe fn traverse_compiled<const AVX2: bool, L: LeafData + ?Sized>(
    nodes: &[CwBvhNode],
    ray: &BoxRay,
    range: &mut f32,
    leaves: &L,
    fetch_ahead: bool,
    test: &mut impl LeafTest,
) -> bool {
    traverse_in_order::<AVX2, false, L, Fixed>(nodes, &Fixed, ray, range, leaves, fetch_ahead, test)
}

/// A closest-hit test from a closure: `leaf(slot, t_max)` returns the primitive's distance
/// when it is hit nearer than `t_max`.
struct Nearest<F>(F);

impl<F: FnMut(usize, f32) -> Option<f32>> LeafTest for Nearest<F> {
    #[inline(always)]
    fn test(&mut self, slot: usize, range: &mut f32) -> bool {
        if let Some(t) = (self.0)(slot, *range) {
            *range = t;
        }
        false
    }
}

/// An any-hit test from a closure: `hit(slot)`.
struct AnyOf<F>(F);

impl<F: FnMut(usize) -> bool> LeafTest for AnyOf<F> {
    #[inline(always)]
    fn test(&mut self, slot: usize, _: &mut f32) -> bool {
        (self.0)(slot)
    }
}

/// The closest primitive along `ray` for t in [0, `t_max`]: `leaf(slot, t_max)` tests the one
/// at `slot` and returns its distance when it is hit nearer than `t_max`, which then becomes the
/// range. Returns the final range: below `t_max` exactly when something was hit. The child
/// boxes come from `boxes`, visited nearest first ([`nearest_first`]); `leaves` and
/// `fetch_ahead` as in [`traverse_compiled`].
#[inline]
pub fn closest_hit<L: LeafData + ?Sized, B: ChildBoxes>(
    nodes: &[B::Node],
    boxes: &B,
    ray: &BoxRay,
    t_max: f32,
    leaves: &L,
    fetch_ahead: bool,
    leaf: impl FnMut(usize, f32) -> Option<f32>,
) -> f32 {
    let mut range = t_max;
    traverse::<true, L, B>(
        nodes,
        boxes,
        ray,
        &mut range,
        leaves,
        fetch_ahead,
        &mut Nearest(leaf),
    );
    range
}

/// True when `hit(slot)` holds for some primitive along `ray` for t in [0, `t_max`] (visited,
/// with `boxes`, `leaves` and `fetch_ahead`, as in [`closest_hit`]); stops at the first.
#[inline]
pub fn any_hit<L: LeafData + ?Sized, B: ChildBoxes>(
    nodes: &[B::Node],
    boxes: &B,
    ray: &BoxRay,
    t_max: f32,
    leaves: &L,
    fetch_ahead: bool,
    hit: impl FnMut(usize) -> bool,
) -> bool {
    let mut range = t_max;
    traverse::<false, L, B>(
        nodes,
        boxes,
        ray,
        &mut range,
        leaves,
        fetch_ahead,
        &mut AnyOf(hit),
    )
}

/// The traversal the queries share, compiled twice: for AVX2 and for the baseline
/// ([`crate::platform::cpu::run`]). `NEAREST` visits children nearest first ([`nearest_first`]),
/// otherwise in the layout's octant order ([`traverse_groups`]).
#[inline]
fn traverse<const NEAREST: bool, L: LeafData + ?Sized, B: ChildBoxes>(
    nodes: &[B::Node],
    boxes: &B,
    ray: &BoxRay,
    range: &mut f32,
    leaves: &L,
    fetch_ahead: bool,
    leaf: &mut impl LeafTest,
) -> bool {
    crate::platform::cpu::run(Traversal::<NEAREST, _, _, _> {
        nodes,
        boxes,
        ray,
        range,
        leaves,
        fetch_ahead,
        leaf,
    })
}

/// The arguments of [`traverse`], as work for [`crate::platform::cpu::run`].
struct Traversal<'a, const NEAREST: bool, L: ?Sized, B: ChildBoxes, T> {
    nodes: &'a [B::Node],
    boxes: &'a B,
    ray: &'a BoxRay,
    range: &'a mut f32,
    leaves: &'a L,
    fetch_ahead: bool,
    leaf: &'a mut T,
}

impl<const NEAREST: bool, L: LeafData + ?Sized, B: ChildBoxes, T: LeafTest>
    crate::platform::cpu::TwoWays for Traversal<'_, NEAREST, L, B, T>
{
    type Output = bool;

    #[inline(always)]
    unsafe fn run<const AVX2: bool>(self) -> bool {
        let t = self;
        traverse_in_order::<AVX2, NEAREST, L, B>(
            t.nodes,
            t.boxes,
            t.ray,
            t.range,
            t.leaves,
            t.fetch_ahead,
            t.leaf,
        )
    }
}

/// [`nearest_first`] when `NEAREST`, otherwise [`traverse_groups`], each with its own stack.
#[inline(always)]
fn traverse_in_order<const AVX2: bool, const NEAREST: bool, L: LeafData + ?Sized, B: ChildBoxes>(
    nodes: &[B::Node],
    boxes: &B,
    ray: &BoxRay,
    range: &mut f32,
    leaves: &L,
    fetch_ahead: bool,
    leaf: &mut impl LeafTest,
) -> bool {
    if NEAREST {
        nearest_first::<AVX2, WAITING_SLOTS, L, B>(
            nodes,
            boxes,
            ray,
            range,
            leaves,
            fetch_ahead,
            leaf,
        )
    } else {
        traverse_groups::<AVX2, STACK, L, B>(nodes, boxes, ray, range, leaves, fetch_ahead, leaf)
    }
}

/// A node's children still to visit: `base` is the first child node (or first primitive) and
/// `bits` marks the children, as the layout encodes them (inner children in the top byte by
/// visiting priority with the node's inner-child mask in the bottom byte; primitives in the low
/// 24 bits by their offset from `base`).
#[derive(Clone, Copy, Default)]
struct Group {
    base: u32,
    bits: u32,
}

/// What a traversal has still to visit: a fixed array on the thread's stack, spilling onto the
/// heap past `N` (a lopsided tree). Uninitialised: only slots below `depth` are read, each
/// after it was written (zeroing the array, and making an empty spill vector, cost every query
/// stores of its own).
struct SpillingStack<T, const N: usize> {
    slots: [MaybeUninit<T>; N],
    depth: usize,
    spilled: Option<Vec<T>>,
}

impl<T: Copy, const N: usize> SpillingStack<T, N> {
    #[inline(always)]
    fn new() -> Self {
        Self {
            slots: [const { MaybeUninit::uninit() }; N],
            depth: 0,
            spilled: None,
        }
    }

    #[inline(always)]
    fn push(&mut self, item: T) {
        if self.depth < N {
            self.slots[self.depth].write(item);
            self.depth += 1;
        } else {
            self.spilled.get_or_insert_with(Vec::new).push(item);
            #[cfg(test)]
            tests::SPILLS.with(|n| n.set(n.get() + 1));
        }
    }

    /// The item pushed last (spilled ones first: they were pushed after the array filled).
    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        if let Some(item) = self.spilled.as_mut().and_then(Vec::pop) {
            return Some(item);
        }
        if self.depth == 0 {
            return None;
        }
        self.depth -= 1;
        // SAFETY: slot `depth` was written when `depth` last passed it going up.
        Some(unsafe { self.slots[self.depth].assume_init_read() })
    }
}

/// Ylitie et al.'s stack of node groups: a node's hit primitives are tested first, then its
/// hit inner children in octant order, the rest of a group waiting on the stack. Returns true
/// when `leaf` asked to stop.
#[inline(always)]
fn traverse_groups<
    const AVX2: bool,
    const STACK_SLOTS: usize,
    L: LeafData + ?Sized,
    B: ChildBoxes,
>(
    tree: &[B::Node],
    boxes: &B,
    ray: &BoxRay,
    range: &mut f32,
    leaves: &L,
    fetch_ahead: bool,
    leaf: &mut impl LeafTest,
) -> bool {
    if tree.is_empty() {
        return false;
    }
    let mut stack = SpillingStack::<Group, STACK_SLOTS>::new();
    // The root is the one inner child of an imaginary parent, in the top slot.
    let mut nodes = Group {
        base: 0,
        bits: 0x8000_0000,
    };
    let mut primitives = Group::default();
    loop {
        while primitives.bits != 0 {
            let offset = 31 - primitives.bits.leading_zeros();
            primitives.bits &= !(1 << offset);
            if leaf.test((primitives.base + offset) as usize, range) {
                return true;
            }
        }
        if nodes.bits & INNER_BITS != 0 {
            let priority = 31 - nodes.bits.leading_zeros();
            let inner_mask = nodes.bits & 0xff;
            nodes.bits &= !(1 << priority);
            let slot = (priority - 24) ^ ray.octant_order;
            // Inner children are stored in slot order: count those in lower slots.
            let index = nodes.base + (inner_mask & ((1 << slot) - 1)).count_ones();
            if nodes.bits & INNER_BITS != 0 {
                stack.push(nodes);
            }
            let node = &tree[index as usize];
            let hits = children_hit::<AVX2, B>(boxes, node, ray, *range);
            let node = node.layout();
            if fetch_ahead && hits & INNER_BITS != 0 {
                prefetch_inner_children(tree, node);
            }
            nodes = Group {
                base: node.child_base_idx,
                bits: (hits & INNER_BITS) | node.imask as u32,
            };
            primitives = Group {
                base: node.primitive_base_idx,
                bits: hits & !INNER_BITS,
            };
            if fetch_ahead {
                prefetch_leaves(leaves, primitives);
            }
        } else if primitives.bits == 0 {
            match stack.pop() {
                Some(group) => nodes = group,
                None => return false,
            }
        }
    }
}

/// Asks the cache for the leaf data of the primitives `group` names. Out of line, as is
/// [`prefetch_inner_children`]: inlined, they left the traversal too big to take in the leaf
/// tests, which cost small scenes more than the call costs large ones.
#[inline(never)]
fn prefetch_leaves<L: LeafData + ?Sized>(leaves: &L, group: Group) {
    if group.bits != 0 {
        let first = (group.base + group.bits.trailing_zeros()) as usize;
        let last = (group.base + 31 - group.bits.leading_zeros()) as usize;
        leaves.prefetch(first..=last);
    }
}

/// A node a nearest-first traversal has still to visit, and where the ray enters its box.
#[derive(Clone, Copy)]
struct Waiting {
    index: u32,
    entry: f32,
}

/// Waiting nodes that fit on [`nearest_first`]'s fixed stack: up to seven a level.
const WAITING_SLOTS: usize = 7 * STACK;

/// A closest-hit traversal that visits each node's children nearest entry first and keeps
/// every waiting node's entry distance, so a node the range has shrunk past since it was met
/// is dropped without reading it. Where the octant order of [`traverse_groups`] is only a
/// guess, this finds the nearest hit before the boxes behind it (a ray through a dense band of
/// strands meets many overlapping boxes). A node's leaves are tested before its inner
/// children, nearest first, and stop at the first beyond the range. Returns true when `leaf`
/// asked to stop.
#[inline(always)]
fn nearest_first<
    const AVX2: bool,
    const STACK_SLOTS: usize,
    L: LeafData + ?Sized,
    B: ChildBoxes,
>(
    tree: &[B::Node],
    boxes: &B,
    ray: &BoxRay,
    range: &mut f32,
    leaves: &L,
    fetch_ahead: bool,
    leaf: &mut impl LeafTest,
) -> bool {
    if tree.is_empty() {
        return false;
    }
    let mut stack = SpillingStack::<Waiting, STACK_SLOTS>::new();
    let mut next = Waiting {
        index: 0,
        entry: 0.0,
    };
    loop {
        if next.entry <= *range {
            let node = &tree[next.index as usize];
            let (lanes, entries) = boxes.slab_entries::<AVX2>(node, ray, *range);
            let node = node.layout();
            let inner = lanes & node.imask as u32;
            if fetch_ahead {
                if inner != 0 {
                    prefetch_inner_children(tree, node);
                }
                if lanes != inner {
                    prefetch_leaf_lanes(leaves, node, lanes & !inner);
                }
            }
            let (order, count) = nearest_lanes(lanes, &entries);
            for &(entry, slot) in &order[..count] {
                if inner & (1 << slot) != 0 {
                    continue;
                }
                if entry > *range {
                    break;
                }
                for primitive in leaf_slots(node, slot as usize) {
                    if leaf.test(primitive as usize, range) {
                        return true;
                    }
                }
            }
            // Inner children farthest first onto the stack; the nearest is visited next.
            let mut nearest = None;
            for &(entry, slot) in order[..count].iter().rev() {
                if inner & (1 << slot) == 0 || entry > *range {
                    continue;
                }
                let child = Waiting {
                    index: inner_child(node, slot as usize),
                    entry,
                };
                if let Some(farther) = nearest.replace(child) {
                    stack.push(farther);
                }
            }
            if let Some(child) = nearest {
                next = child;
                continue;
            }
        }
        match stack.pop() {
            Some(waiting) => next = waiting,
            None => return false,
        }
    }
}

/// The slots of `lanes` with their entry distances, nearest first (by insertion: a node has at
/// most eight), and how many there are.
#[inline(always)]
fn nearest_lanes(lanes: u32, entries: &[f32; 8]) -> ([(f32, u32); 8], usize) {
    let mut order = [(0.0f32, 0u32); 8];
    let mut count = 0;
    let mut bits = lanes;
    while bits != 0 {
        let slot = bits.trailing_zeros();
        bits &= bits - 1;
        let entry = entries[slot as usize];
        let mut at = count;
        while at > 0 && order[at - 1].0 > entry {
            order[at] = order[at - 1];
            at -= 1;
        }
        order[at] = (entry, slot);
        count += 1;
    }
    (order, count)
}

/// Asks the cache for the leaf data of `node`'s leaf children in `leaf_lanes` (their
/// primitives lie together from the node's first).
#[inline(never)]
fn prefetch_leaf_lanes<L: LeafData + ?Sized>(leaves: &L, node: &CwBvhNode, leaf_lanes: u32) {
    let (mut first, mut last) = (u32::MAX, 0);
    let mut bits = leaf_lanes;
    while bits != 0 {
        let run = leaf_slots(node, bits.trailing_zeros() as usize);
        bits &= bits - 1;
        if !run.is_empty() {
            first = first.min(run.start);
            last = last.max(run.end - 1);
        }
    }
    if first <= last {
        leaves.prefetch(first as usize..=last as usize);
    }
}

/// The primitives (slots) of `node`'s leaf child in `slot`: the meta byte keeps the first's
/// offset from the node's first primitive in its low five bits and the count in unary above
/// (none for an empty slot).
#[inline(always)]
pub(super) fn leaf_slots(node: &CwBvhNode, slot: usize) -> std::ops::Range<u32> {
    let meta = node.child_meta[slot];
    let first = node.primitive_base_idx + (meta & 0x1f) as u32;
    first..first + (meta >> 5).count_ones()
}

/// The node index of `node`'s inner child in `slot`: inner children lie together from
/// `child_base_idx` in slot order.
#[inline(always)]
pub(super) fn inner_child(node: &CwBvhNode, slot: usize) -> u32 {
    node.child_base_idx + (node.imask as u32 & ((1 << slot) - 1)).count_ones()
}

/// What a leaf test reads for the primitives at a run of slots, which a traversal of a large
/// tree asks the cache for as soon as it knows the slots.
pub trait LeafData {
    fn prefetch(&self, slots: RangeInclusive<usize>);
}

/// Items stored in the tree's primitive order, one a slot.
impl<T> LeafData for [T] {
    #[inline(always)]
    fn prefetch(&self, slots: RangeInclusive<usize>) {
        if let Some(run) = self.get(slots) {
            prefetch(run);
        }
    }
}

/// Asks the cache for `node`'s inner children, some of which a ray meets: nodes are visited
/// one at a time and each first touch of a large tree's node otherwise waits on memory.
#[inline(never)]
fn prefetch_inner_children<N>(nodes: &[N], node: &CwBvhNode) {
    // Inner children lie together from `child_base_idx`; fetch the lines of them all when
    // any is hit (cheaper than ranking each hit slot, and most are hit when any is).
    let first = node.child_base_idx as usize;
    let all = (node.imask.count_ones() as usize).min(nodes.len().saturating_sub(first));
    prefetch(&nodes[first..first + all]);
}

/// A node as a traversal reads it: its layout (children, primitives and their meta bytes) is
/// obvhs' node, with whatever else its boxes need around it.
pub trait WideNode {
    fn layout(&self) -> &CwBvhNode;
}

impl WideNode for CwBvhNode {
    #[inline(always)]
    fn layout(&self) -> &CwBvhNode {
        self
    }
}

/// How a traversal reads a node's child boxes: as the nodes hold them ([`Fixed`]), or moving
/// over a time slice ([`Swept`]).
pub trait ChildBoxes {
    type Node: WideNode;

    /// One bit per child slot of `node` whose box `ray` meets within [0, `t_max`], and per
    /// slot where the ray enters its box (meaningful for the slots whose bit is set).
    fn slab_entries<const AVX2: bool>(
        &self,
        node: &Self::Node,
        ray: &BoxRay,
        t_max: f32,
    ) -> (u32, [f32; 8]);

    /// The bits of [`Self::slab_entries`] alone.
    #[inline(always)]
    fn slab_hits<const AVX2: bool>(&self, node: &Self::Node, ray: &BoxRay, t_max: f32) -> u32 {
        self.slab_entries::<AVX2>(node, ray, t_max).0
    }
}

/// Child boxes as obvhs' nodes hold them: a tree that stands still.
pub struct Fixed;

impl ChildBoxes for Fixed {
    type Node = CwBvhNode;

    #[inline(always)]
    fn slab_entries<const AVX2: bool>(
        &self,
        node: &CwBvhNode,
        ray: &BoxRay,
        t_max: f32,
    ) -> (u32, [f32; 8]) {
        #[cfg(target_arch = "x86_64")]
        if AVX2 {
            // SAFETY: `AVX2` is set only in the AVX2 compilation that `crate::platform::cpu::run` picks
            // where the processor has it.
            return unsafe { slab_hits_avx2(node, None, ray, t_max) };
        }
        slab_hits_portable(node, None, ray, t_max)
    }
}

/// A node of a tree whose primitives move, for one time slice: the layout, one grid, and each
/// child's planes at the slice's start and at its end on that grid, in two cache lines (see
/// [`super::moving_bvh`]).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub struct SweptNode {
    /// The layout, the grid both plane sets share, and the planes at the slice's start.
    pub start: CwBvhNode,
    /// The planes at the slice's end, rows as [`plane_rows`] lists them (lower x, upper x,
    /// lower y, ...).
    pub end: [[u8; 8]; 6],
}

impl WideNode for SweptNode {
    #[inline(always)]
    fn layout(&self) -> &CwBvhNode {
        &self.start
    }
}

/// Child boxes that move over a time slice, taken at fraction `at` through it: each plane runs
/// linearly from its place at the slice's start to its place at the end. A tree whose
/// primitives move is then bounded about as tightly as one that stands still, where boxes over
/// the whole slice grow by the motion.
pub struct Swept {
    pub at: f32,
}

impl ChildBoxes for Swept {
    type Node = SweptNode;

    #[inline(always)]
    fn slab_entries<const AVX2: bool>(
        &self,
        node: &SweptNode,
        ray: &BoxRay,
        t_max: f32,
    ) -> (u32, [f32; 8]) {
        let end = Some((&node.end, self.at));
        #[cfg(target_arch = "x86_64")]
        if AVX2 {
            // SAFETY: as for `Fixed`.
            return unsafe { slab_hits_avx2(&node.start, end, ray, t_max) };
        }
        slab_hits_portable(&node.start, end, ray, t_max)
    }
}

/// The children of `node` (boxes read by `boxes`) that `ray` meets within [0, `t_max`], as
/// group bits (see [`Group`]).
#[inline(always)]
fn children_hit<const AVX2: bool, B: ChildBoxes>(
    boxes: &B,
    node: &B::Node,
    ray: &BoxRay,
    t_max: f32,
) -> u32 {
    let lanes = boxes.slab_hits::<AVX2>(node, ray, t_max);
    if lanes == 0 {
        return 0;
    }
    let meta = u64::from_le_bytes(node.layout().child_meta);
    let order = ray.octant_order as u64 * 0x0101_0101_0101_0101;
    // An inner child's meta byte is 24 + its slot (bits 3 and 4 both set, which a leaf's
    // primitive offset below 24 never has); it is visited at priority 24 + (slot ^ order).
    let inner = (meta & (meta << 1)) & 0x1010_1010_1010_1010;
    let inner_bytes = (inner >> 4) * 0xff;
    let shift = (meta ^ (order & inner_bytes)) & 0x1f1f_1f1f_1f1f_1f1f;
    // An inner child contributes one bit; a leaf its primitive count in unary.
    let count = (meta >> 5) & 0x0707_0707_0707_0707;
    let mut bits = 0u32;
    let mut lanes = lanes;
    while lanes != 0 {
        let c = lanes.trailing_zeros();
        lanes &= lanes - 1;
        let byte = |v: u64| ((v >> (8 * c)) & 0xff) as u32;
        bits |= byte(count) << byte(shift);
    }
    bits
}

/// A node's quantized planes per axis, as (lower, upper) byte rows.
#[inline(always)]
fn plane_rows(node: &CwBvhNode) -> [(&[u8; 8], &[u8; 8]); 3] {
    [
        (&node.child_min_x, &node.child_max_x),
        (&node.child_min_y, &node.child_max_y),
        (&node.child_min_z, &node.child_max_z),
    ]
}

/// The planes of a [`SweptNode`] at the end of its slice, and how far through the slice a
/// query looks.
type EndPlanes<'a> = Option<(&'a [[u8; 8]; 6], f32)>;

/// Axis `a`'s grid of `node` over the ray: (scale, offset) taking a quantized plane to its
/// ray distance.
#[inline(always)]
fn grid_over_ray(node: &CwBvhNode, a: usize, ray: &BoxRay) -> (f32, f32) {
    let grid = f32::from_bits((node.e[a] as u32) << 23);
    (
        grid * ray.inv_dir[a],
        (node.p[a] - ray.origin[a]) * ray.inv_dir[a],
    )
}

/// The slab tests of [`ChildBoxes::slab_hits`] in plain arrays, for any processor: `node`'s
/// boxes, or with `end` the boxes that far between them and the end planes.
#[inline(always)]
fn slab_hits_portable(
    node: &CwBvhNode,
    end: EndPlanes,
    ray: &BoxRay,
    t_max: f32,
) -> (u32, [f32; 8]) {
    let mut near = [0.0f32; 8];
    let mut far = [t_max; 8];
    for (a, rows) in plane_rows(node).into_iter().enumerate() {
        let (scale, offset) = grid_over_ray(node, a, ray);
        let [lo, hi] = [0, 1].map(|side| {
            let row = if side == 0 { rows.0 } else { rows.1 };
            std::array::from_fn::<f32, 8, _>(|c| {
                let mut q = row[c] as f32;
                if let Some((end, at)) = end {
                    q += at * (end[2 * a + side][c] as f32 - q);
                }
                q * scale + offset
            })
        });
        let (entry, exit) = if ray.down[a] { (hi, lo) } else { (lo, hi) };
        for c in 0..8 {
            near[c] = if entry[c] > near[c] {
                entry[c]
            } else {
                near[c]
            };
            far[c] = if exit[c] < far[c] { exit[c] } else { far[c] };
        }
    }
    let mut lanes = 0u32;
    for c in 0..8 {
        lanes |= ((near[c] <= far[c]) as u32) << c;
    }
    (lanes, near)
}

/// Eight quantized planes widened to floats at once.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn widen_avx2(row: &[u8; 8]) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    // SAFETY: `row` is eight readable bytes, which an unaligned 64-bit load reads.
    let packed = unsafe { _mm_loadl_epi64(row.as_ptr().cast()) };
    _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(packed))
}

/// The slab tests of [`slab_hits_portable`] in AVX2 registers, the eight comparisons gathered
/// by one movemask. A swept node's two plane sets share its grid, so they mix before the one
/// scaling to ray distances.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn slab_hits_avx2(node: &CwBvhNode, end: EndPlanes, ray: &BoxRay, t_max: f32) -> (u32, [f32; 8]) {
    use std::arch::x86_64::*;
    let mut near = _mm256_setzero_ps();
    let mut far = _mm256_set1_ps(t_max);
    for (a, (lo, hi)) in plane_rows(node).into_iter().enumerate() {
        let (scale, offset) = grid_over_ray(node, a, ray);
        let (scale, offset) = (_mm256_set1_ps(scale), _mm256_set1_ps(offset));
        let mut planes = [widen_avx2(lo), widen_avx2(hi)];
        if let Some((end, at)) = end {
            let at = _mm256_set1_ps(at);
            for (side, q) in planes.iter_mut().enumerate() {
                let toward = _mm256_sub_ps(widen_avx2(&end[2 * a + side]), *q);
                *q = _mm256_add_ps(*q, _mm256_mul_ps(at, toward));
            }
        }
        let [t_lo, t_hi] = planes.map(|q| _mm256_add_ps(_mm256_mul_ps(q, scale), offset));
        // The entry plane is the nearer of the two whichever way the ray runs (the distance
        // is monotonic in the plane): a minimum, not a branch on the ray's direction that
        // each new ray's signs mispredict.
        near = _mm256_max_ps(near, _mm256_min_ps(t_lo, t_hi));
        far = _mm256_min_ps(far, _mm256_max_ps(t_lo, t_hi));
    }
    let mut entries = [0.0f32; 8];
    // SAFETY: `entries` is eight writable floats, which an unaligned store writes.
    unsafe { _mm256_storeu_ps(entries.as_mut_ptr(), near) };
    let lanes = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
    (lanes, entries)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::triangle::{ShearedRay, Triangle, intersect_watertight};
    use crate::geometry::triangle_bvh::build_cwbvh;
    use std::cell::Cell;

    thread_local! {
        /// Groups this thread's traversals put on the heap.
        pub static SPILLS: Cell<usize> = const { Cell::new(0) };
    }

    /// Nearest hit by testing every triangle.
    fn brute(tris: &[Triangle], origin: Vec3, dir: Vec3, t_max: f32) -> Option<f32> {
        let sheared = ShearedRay::new(origin, dir);
        tris.iter()
            .filter_map(|t| intersect_watertight(&sheared, t, t_max).map(|h| h.0))
            .min_by(f32::total_cmp)
    }

    /// Both queries against brute force on `tris` for rays from `origins` in many directions,
    /// including ones exactly along the axes (with −0.0 components), ones from inside boxes,
    /// and one at each triangle's centroid, so every subtree holds a hit some ray must find (a
    /// slab test that drops one child slot fails here).
    fn agree_with_brute_force(tris: &[Triangle], origins: &[Vec3]) {
        let bvh = build_cwbvh(tris);
        let mut directions: Vec<Vec3> = (0..200)
            .map(|k| {
                let (a, b) = (k as f32 * 2.399, (k as f32 * 0.618).fract() * 2.0 - 1.0);
                Vec3::new(
                    a.cos() * (1.0 - b * b).sqrt(),
                    a.sin() * (1.0 - b * b).sqrt(),
                    b,
                )
            })
            .collect();
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            directions.push(axis);
            directions.push(-axis);
            directions.push(Vec3::select(
                axis.cmpeq(Vec3::ZERO),
                Vec3::splat(-0.0),
                axis,
            ));
        }
        let mut aimed_hits = 0;
        for &origin in origins {
            let aimed = tris
                .iter()
                .map(|t| ((t.v[0] + t.v[1] + t.v[2]) / 3.0 - origin).normalize());
            for (k, dir) in directions.iter().copied().chain(aimed).enumerate() {
                let is_aimed = k >= directions.len();
                let sheared = ShearedRay::new(origin, dir);
                let ray = BoxRay::new(origin, dir);
                // Fetching ahead (the large trees' path) must change nothing found.
                for (t_max, ahead) in [(f32::INFINITY, false), (0.5, false), (0.5, true)] {
                    let expected = brute(tris, origin, dir, t_max);
                    let t = closest_hit(
                        &bvh.nodes,
                        &Fixed,
                        &ray,
                        t_max,
                        tris,
                        ahead,
                        |slot, range| {
                            let tri = &tris[bvh.primitive_indices[slot] as usize];
                            intersect_watertight(&sheared, tri, range).map(|h| h.0)
                        },
                    );
                    assert_eq!(
                        (t < t_max).then_some(t),
                        expected,
                        "closest from {origin} along {dir} to {t_max}"
                    );
                    let any = any_hit(&bvh.nodes, &Fixed, &ray, t_max, tris, ahead, |slot| {
                        let tri = &tris[bvh.primitive_indices[slot] as usize];
                        intersect_watertight(&sheared, tri, t_max).is_some()
                    });
                    assert_eq!(any, expected.is_some(), "any from {origin} along {dir}");
                    aimed_hits +=
                        (is_aimed && t_max == f32::INFINITY && expected.is_some()) as usize;
                }
            }
        }
        // Every ray aimed at a centroid hits something.
        assert_eq!(aimed_hits, origins.len() * tris.len());
    }

    /// 400 small triangles scattered through a 4 m cube.
    fn cloud() -> Vec<Triangle> {
        (0..400)
            .map(|k| {
                let c = Vec3::new(
                    (k as f32 * 0.37).sin() * 2.0,
                    (k as f32 * 0.73).cos() * 2.0,
                    (k as f32 * 1.31).sin() * 2.0,
                );
                let s = 0.05 + 0.1 * (k as f32 * 0.11).sin().abs();
                Triangle {
                    v: [
                        c,
                        c + Vec3::new(s, 0.0, 0.0),
                        c + Vec3::new(0.0, s, s * 0.5),
                    ],
                }
            })
            .collect()
    }

    #[test]
    fn queries_match_brute_force_on_a_cloud() {
        let tris = cloud();
        let origins = [Vec3::ZERO, Vec3::new(5.0, -3.0, 1.0)];
        agree_with_brute_force(&tris, &origins);
        // And as a processor without AVX2 runs them.
        crate::platform::cpu::with_baseline(|| agree_with_brute_force(&tris, &origins));
    }

    #[test]
    fn both_traversals_spill_beyond_a_fixed_stack_and_still_visit_everything() {
        // A one-slot stack: the second group (or node) waiting goes to the heap.
        let tris = cloud();
        let bvh = build_cwbvh(&tris);
        SPILLS.with(|n| n.set(0));
        let mut nearest_spills = 0;
        for k in 0..500 {
            let origin = Vec3::new((k as f32 * 0.3).sin(), (k as f32 * 0.7).cos(), 0.0) * 3.0;
            let dir = (Vec3::new((k as f32 * 1.1).cos(), (k as f32 * 0.9).sin(), 0.4) - origin)
                .normalize();
            let sheared = ShearedRay::new(origin, dir);
            let mut range = f32::INFINITY;
            let mut nearest = Nearest(|slot: usize, r: f32| {
                let tri = &tris[bvh.primitive_indices[slot] as usize];
                intersect_watertight(&sheared, tri, r).map(|h| h.0)
            });
            let ray = BoxRay::new(origin, dir);
            let expected = brute(&tris, origin, dir, f32::INFINITY);
            traverse_groups::<false, 1, [Triangle], Fixed>(
                &bvh.nodes,
                &Fixed,
                &ray,
                &mut range,
                &[],
                false,
                &mut nearest,
            );
            assert_eq!(range.is_finite().then_some(range), expected, "ray {k}");
            let spilled = SPILLS.with(Cell::get);
            range = f32::INFINITY;
            nearest_first::<false, 1, [Triangle], Fixed>(
                &bvh.nodes,
                &Fixed,
                &ray,
                &mut range,
                &[],
                false,
                &mut nearest,
            );
            assert_eq!(range.is_finite().then_some(range), expected, "ray {k}");
            nearest_spills += SPILLS.with(Cell::get) - spilled;
        }
        assert!(
            SPILLS.with(Cell::get) > nearest_spills,
            "no group traversal spilled"
        );
        assert!(nearest_spills > 0, "no nearest-first traversal spilled");
    }

    #[test]
    fn boxes_are_met_from_the_origin_on() {
        let ray = BoxRay::new(Vec3::ZERO, -Vec3::Z);
        // A flat box 1 µm away, and one the origin lies in.
        assert_eq!(
            ray.enters(
                Vec3::new(-1.0, -1.0, -1e-6),
                Vec3::new(1.0, 1.0, -1e-6),
                1.0
            ),
            Some(1e-6)
        );
        assert_eq!(
            ray.enters(Vec3::splat(-1.0), Vec3::splat(1.0), 1.0),
            Some(0.0)
        );
        assert_eq!(
            ray.enters(Vec3::new(-1.0, -1.0, 1e-6), Vec3::splat(1.0), 1.0),
            None
        );
        assert_eq!(
            ray.enters(Vec3::new(-1.0, -1.0, -3.0), Vec3::new(1.0, 1.0, -2.0), 1.0),
            None
        );
    }
}
