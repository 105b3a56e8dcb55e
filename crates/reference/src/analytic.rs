//! Analytic visibility of any opaque triangle mesh under a rectangle light, without sampling.
//!
//! **What it computes.** Seen from a receiver point `p`, every caster triangle between the light
//! plane and `p` projects through `p` onto the light's plane as a polygon; the visible fraction of
//! the light is its area minus the area of the union of those polygons clipped to the light, over
//! its area. Atty et al. 2006 (sections 3.3 and 3.4) do this for rectangles parallel to the light
//! ([`crate::exact`]); the projection is a central projection, so it holds for any triangle: a
//! triangle projects to a triangle while it lies strictly between the two planes.
//!
//! **What counts as between.** The same open segment the sampled answers test
//! ([`crate::raycast`]): a point `q` of the light is hidden when the segment from `p` to `q` meets
//! a caster at a parameter `t` in `(SEGMENT_EPSILON, 1 - LIGHT_END_EPSILON)` (`t = 0` at `p`).
//! Along that segment the light-space depth is `p.z (1 - t)`, so this is the slab of depths
//! `(LIGHT_END_EPSILON p.z, (1 - SEGMENT_EPSILON) p.z)`: each triangle is clipped to it before it
//! is projected. That defines every degenerate case the same way as the ray cast does, with no
//! sampling left:
//! - a triangle through `p` (its plane contains `p`) projects to a segment: no area;
//! - a triangle seen edge-on from `p` likewise; one edge-on to the light (perpendicular to its
//!   plane) is an ordinary triangle from `p`;
//! - a caster touching the receiver (contact), or `p` lying on a caster: the part within
//!   `SEGMENT_EPSILON p.z` of `p`'s depth is cut away, as the ray cast ignores hits that near the
//!   receiver (the G-buffer's f32 positions lie on either side of their surface by more than
//!   rounding), and the rest projects within `1 / SEGMENT_EPSILON` times the light's distance;
//! - a polygon edge on the light's edge: the union is clipped to the light rectangle, so a
//!   zero-width sliver along it adds nothing.
//!
//! A light of zero area has no rectangle to clip to; [`AnalyticCasters::new`] refuses it and the
//! caller uses a sampled answer.
//!
//! **How.** Per point (in parallel over pixels with rayon): the caster triangles whose bounding
//! boxes meet the pyramid from `p` to the light, from a BVH over their light-space boxes; each
//! one inside the slab is projected (f64); the union's area is that of the region the projected
//! triangles cover at least once, counted with the nonzero winding rule (each triangle oriented
//! counter-clockwise). A shared edge of two neighbouring triangles whose projections lie on
//! either side of it cancels, so what reaches the polygon library is the projected silhouette of
//! each mesh (plus the outline of any triangle the slab cuts): a closed mesh contributes its
//! silhouette loops only, not its triangles. The loops are clipped to the light rectangle
//! (Sutherland-Hodgman, which keeps the winding number inside the rectangle) and their union's
//! area is computed by `i_overlay` with its 64-bit integer engine (docs/EXACT.md, "The
//! analytic exact answer", says why that library).

use std::collections::HashMap;
use std::sync::atomic::Ordering;

use i_overlay::core::{fill_rule::FillRule, overlay_rule::OverlayRule};
use i_overlay::float::overlay::FloatOverlay;
use rayon::prelude::*;
use softshadow_core::{glam::Vec3, AreaLight, BuildControl, Scene};

use crate::raycast::{LIGHT_END_EPSILON, SEGMENT_EPSILON};

/// Triangles per BVH leaf at most.
const LEAF_SIZE: usize = 4;
/// No neighbour across an edge (a mesh border, a non-manifold edge, a degenerate triangle).
const NONE: u32 = u32::MAX;

/// A 2D point on the light plane (light-space x, y).
type P2 = [f64; 2];

/// A node of the light-space BVH: a leaf when `count > 0` (triangles `first .. first + count`),
/// else interior with children `first` and `first + 1`.
#[derive(Clone, Copy, Debug)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    first: u32,
    count: u32,
}

/// The casters of a scene in light space, ready for [`AnalyticCasters::visible_fraction`]:
/// welded vertices (f64), triangles as vertex ids, the neighbour across each edge and a BVH.
#[derive(Clone, Debug)]
pub struct AnalyticCasters {
    /// Half extents of the light rectangle.
    half: P2,
    vertices: Vec<[f64; 3]>,
    /// Triangles in BVH leaf order.
    triangles: Vec<[u32; 3]>,
    /// Per triangle and edge `k` (from vertex `k` to `k + 1`): the triangle across it and whether
    /// that triangle runs the edge the same way (bit 31), or [`NONE`].
    neighbours: Vec<[u32; 3]>,
    nodes: Vec<Node>,
}

/// The analytic answer cannot be computed for this scene.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AnalyticError {
    /// The light has no area: no rectangle to clip the union to (the sampled answers degenerate
    /// to its centre line or point instead).
    #[error("the light is {width} x {height}: the analytic exact answer needs a light of positive area (a sampled answer is used)")]
    NoArea {
        /// The light's width.
        width: f32,
        /// The light's height.
        height: f32,
    },
    /// A caster has an alpha-masked material: the union of the casters' projections cannot see
    /// the holes its texture cuts (a sampled answer, which tests alpha at each hit, is used).
    #[error("scene `{scene}` has alpha-masked casters: the analytic exact answer cannot see their holes (the ray-traced or ray-cast answer is used)")]
    MaskedCasters {
        /// The scene's name.
        scene: String,
    },
    /// The light is not a rectangle: the union of the casters' projections is clipped to a
    /// rectangle here (a disk's or a sphere's answer is sampled instead).
    #[error("the light is a `{kind}`: the analytic exact answer is for rectangle lights (a sampled answer is used)")]
    NotRect {
        /// The light's kind.
        kind: softshadow_core::LightKind,
    },
    /// The work was cancelled (its `BuildControl`) before every pixel was done.
    #[error("the analytic exact answer was cancelled before it finished")]
    Cancelled,
}

/// What a receiver point sees of the light ([`AnalyticCasters::light_seen`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSeen {
    /// The visible fraction of the light's area.
    pub visibility: f64,
    /// The form factor from the point, with its normal, to the visible part of the light: the
    /// exact irradiance over the light's radiance times pi (a Lambertian light).
    pub irradiance: f64,
    /// The same for the whole light, as if nothing were in the way: 0 when the point faces away
    /// from all of it.
    pub unoccluded: f64,
}

impl LightSeen {
    /// At or behind the light plane: nothing of a one-sided light is seen.
    pub const DARK: Self = Self {
        visibility: 0.0,
        irradiance: 0.0,
        unoccluded: 0.0,
    };
}

impl AnalyticCasters {
    /// The casters of `scene` (every `casts_shadow` instance, transformed; triangles with a
    /// non-finite vertex or an out-of-range index are skipped) in the light space of `light`.
    /// Vertices enter light space as the closed form takes them (`AreaLight::to_light_space`, the
    /// scene's own f32 precision); everything after that is f64.
    pub fn new(scene: &Scene, light: &AreaLight) -> Result<Self, AnalyticError> {
        if scene.has_masked_casters() {
            return Err(AnalyticError::MaskedCasters {
                scene: scene.name.clone(),
            });
        }
        if light.kind != softshadow_core::LightKind::Rect {
            return Err(AnalyticError::NotRect { kind: light.kind });
        }
        let half = light.half_extent();
        if !(half.x > 0.0 && half.y > 0.0) {
            return Err(AnalyticError::NoArea {
                width: light.width,
                height: light.height,
            });
        }
        let view = light.view();
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for instance in scene.instances.iter().filter(|i| i.casts_shadow) {
            let Some(mesh) = scene.meshes.get(instance.mesh) else {
                continue;
            };
            for tri in mesh.indices.chunks_exact(3) {
                let mut t = [0u32; 3];
                let mut ok = true;
                for (k, &index) in tri.iter().enumerate() {
                    let Some(p) = mesh.positions.get(index as usize) else {
                        ok = false;
                        break;
                    };
                    let world = instance.transform.transform_point3(*p);
                    if !world.is_finite() {
                        ok = false;
                        break;
                    }
                    // Welded by exact position: flat-shaded meshes split their vertices per face,
                    // and the silhouette needs the neighbour across every edge.
                    let key = world.to_array().map(f32::to_bits);
                    t[k] = *ids.entry(key).or_insert_with(|| {
                        let l: Vec3 = (view * world.extend(1.0)).truncate();
                        vertices.push([l.x as f64, l.y as f64, l.z as f64]);
                        (vertices.len() - 1) as u32
                    });
                }
                // A triangle with two equal corners covers nothing and borders nothing.
                if ok && t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    triangles.push(t);
                }
            }
        }
        let mut casters = Self {
            half: [half.x as f64, half.y as f64],
            vertices,
            triangles,
            neighbours: Vec::new(),
            nodes: Vec::new(),
        };
        casters.build_bvh();
        casters.find_neighbours();
        Ok(casters)
    }

    /// Number of caster triangles (degenerate ones dropped).
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    fn bounds(&self, t: &[u32; 3]) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &v in t {
            let p = self.vertices[v as usize];
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        (lo, hi)
    }

    /// A median-split BVH over the triangles' light-space boxes (the pyramid cull needs boxes,
    /// not a tuned ray-tracing tree).
    fn build_bvh(&mut self) {
        let n = self.triangles.len();
        if n == 0 {
            return;
        }
        let centroid = |s: &Self, t: &[u32; 3]| {
            let mut c = [0.0; 3];
            for &v in t {
                for (a, x) in c.iter_mut().enumerate() {
                    *x += s.vertices[v as usize][a] / 3.0;
                }
            }
            c
        };
        let centroids: Vec<[f64; 3]> = self.triangles.iter().map(|t| centroid(self, t)).collect();
        let mut order: Vec<usize> = (0..n).collect();
        let empty = Node {
            lo: [0.0; 3],
            hi: [0.0; 3],
            first: 0,
            count: 0,
        };
        self.nodes.push(empty);
        let mut work = vec![(0usize, 0usize, n)];
        while let Some((node, start, end)) = work.pop() {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            let mut clo = [f64::INFINITY; 3];
            let mut chi = [f64::NEG_INFINITY; 3];
            for &i in &order[start..end] {
                let (tlo, thi) = self.bounds(&self.triangles[i]);
                for a in 0..3 {
                    lo[a] = lo[a].min(tlo[a]);
                    hi[a] = hi[a].max(thi[a]);
                    clo[a] = clo[a].min(centroids[i][a]);
                    chi[a] = chi[a].max(centroids[i][a]);
                }
            }
            self.nodes[node] = Node {
                lo,
                hi,
                first: start as u32,
                count: (end - start) as u32,
            };
            let axis = (0..3)
                .max_by(|&a, &b| (chi[a] - clo[a]).total_cmp(&(chi[b] - clo[b])))
                .expect("three axes");
            if end - start <= LEAF_SIZE || chi[axis] - clo[axis] <= 0.0 {
                continue;
            }
            let mid = (end - start) / 2;
            order[start..end].select_nth_unstable_by(mid, |&x, &y| {
                centroids[x][axis].total_cmp(&centroids[y][axis])
            });
            let left = self.nodes.len();
            self.nodes.push(empty);
            self.nodes.push(empty);
            self.nodes[node].first = left as u32;
            self.nodes[node].count = 0;
            work.push((left, start, start + mid));
            work.push((left + 1, start + mid, end));
        }
        self.triangles = order.iter().map(|&i| self.triangles[i]).collect();
    }

    /// The neighbour across each edge, where exactly two triangles share it.
    fn find_neighbours(&mut self) {
        let mut edges: HashMap<(u32, u32), Vec<(u32, u32)>> = HashMap::new();
        for (t, tri) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                let (i, j) = (tri[k], tri[(k + 1) % 3]);
                edges
                    .entry((i.min(j), i.max(j)))
                    .or_default()
                    .push((t as u32, k as u32));
            }
        }
        self.neighbours = vec![[NONE; 3]; self.triangles.len()];
        for sharing in edges.values() {
            if let [(t, k), (u, m)] = sharing[..] {
                let first = |t: u32, k: u32| self.triangles[t as usize][k as usize];
                // Bit 31: the neighbour runs the shared edge in the same direction (the mesh is
                // not consistently oriented there).
                let same = ((first(t, k) == first(u, m)) as u32) << 31;
                self.neighbours[t as usize][k as usize] = u | same;
                self.neighbours[u as usize][m as usize] = t | same;
            }
        }
    }

    /// Visible fraction of the light from the light-space point `p` (see the [module
    /// docs](self)): 0 at or behind the light plane or when `p` is not finite, 1 when nothing is
    /// in the way. `scratch` is reused between calls of one thread.
    pub fn visible_fraction(&self, p: Vec3, scratch: &mut Scratch) -> f64 {
        self.light_seen(p, None, scratch).visibility
    }

    /// What the light-space point `p` with the light-space unit normal `normal` sees of the
    /// light: its visible fraction and, with a normal, the exact irradiance from the visible part
    /// and from the whole light, as form factors (Lambert's contour integral,
    /// [`polygon_form_factor`]: the irradiance over the light's radiance times pi). Without a
    /// normal both form factors are 0.
    pub fn light_seen(&self, p: Vec3, normal: Option<Vec3>, scratch: &mut Scratch) -> LightSeen {
        let p = [p.x as f64, p.y as f64, p.z as f64];
        if !p.iter().all(|c| c.is_finite()) || p[2] <= 0.0 {
            return LightSeen::DARK;
        }
        let [a, b] = self.half;
        let covered = self.covered_region(p, scratch);
        let twice_covered: f64 = covered.iter().map(|c| shoelace2(c)).sum();
        let visibility = (1.0 - 0.5 * twice_covered.abs() / (4.0 * a * b)).clamp(0.0, 1.0);
        let Some(n) = normal.filter(|n| n.is_finite() && n.length_squared() > 0.0) else {
            return LightSeen {
                visibility,
                ..LightSeen::DARK
            };
        };
        let n = n.normalize();
        let n = [n.x as f64, n.y as f64, n.z as f64];
        let light = [[-a, -b], [a, -b], [a, b], [-a, b]];
        let unoccluded = polygon_form_factor(p, n, &light).max(0.0);
        let hidden: f64 = covered.iter().map(|c| polygon_form_factor(p, n, c)).sum();
        LightSeen {
            visibility,
            irradiance: (unoccluded - hidden).clamp(0.0, unoccluded),
            unoccluded,
        }
    }

    /// The part of the light hidden from `p` (f64; `p.z > 0`): the union's contours, outer ones
    /// counter-clockwise and holes clockwise (so signed sums over them are sums over the region).
    fn covered_region(&self, p: [f64; 3], scratch: &mut Scratch) -> Vec<Vec<P2>> {
        let slab = [
            LIGHT_END_EPSILON as f64 * p[2],
            (1.0 - SEGMENT_EPSILON as f64) * p[2],
        ];
        scratch.start(self.triangles.len());
        self.collect(p, slab, scratch);
        if scratch.included.is_empty() && scratch.contours.is_empty() {
            return Vec::new();
        }
        self.silhouette_loops(p, scratch);
        let [a, b] = self.half;
        let mut contours = std::mem::take(&mut scratch.contours);
        contours.retain_mut(|c| {
            *c = clip_to_rect(c, a, b);
            c.len() >= 3
        });
        let union = union_contours(&contours);
        scratch.contours = contours;
        union
    }

    /// Walks the BVH over the pyramid from `p` to the light: marks the triangles wholly inside the
    /// slab whose projection meets the light (with their orientation) and adds the clipped
    /// projection of those the slab cuts as contours of their own.
    fn collect(&self, p: [f64; 3], slab: [f64; 2], scratch: &mut Scratch) {
        if self.nodes.is_empty() {
            return;
        }
        let [a, b] = self.half;
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            if !pyramid_meets_box(p, self.half, slab, node) {
                continue;
            }
            if node.count == 0 {
                stack.push(node.first);
                stack.push(node.first + 1);
                continue;
            }
            for t in node.first..node.first + node.count {
                let tri = self.triangles[t as usize];
                let v = tri.map(|i| self.vertices[i as usize]);
                let (zmin, zmax) = (
                    v[0][2].min(v[1][2]).min(v[2][2]),
                    v[0][2].max(v[1][2]).max(v[2][2]),
                );
                if zmax <= slab[0] || zmin >= slab[1] {
                    continue;
                }
                if zmin > slab[0] && zmax < slab[1] {
                    let q = v.map(|o| project(p, o));
                    let area2 = cross(q[0], q[1], q[2]);
                    if area2 == 0.0 || !area2.is_finite() || !meets_rect(&q, a, b) {
                        continue;
                    }
                    scratch.mark(t, area2 > 0.0);
                } else {
                    let mut poly: Vec<P2> = clip_to_slab(&v, slab)
                        .into_iter()
                        .map(|o| project(p, o))
                        .collect();
                    let area2 = shoelace2(&poly);
                    if poly.len() >= 3 && area2 != 0.0 && area2.is_finite() {
                        if area2 < 0.0 {
                            poly.reverse();
                        }
                        scratch.contours.push(poly);
                    }
                }
            }
        }
    }

    /// The boundary of the marked triangles, each oriented counter-clockwise in projection, as
    /// closed loops of projected vertices added to `scratch.contours`: an edge two marked
    /// neighbours run in opposite directions cancels (Stokes: the winding number of the boundary
    /// is the number of marked triangles covering a point).
    fn silhouette_loops(&self, p: [f64; 3], scratch: &mut Scratch) {
        let mut edges: Vec<(u32, u32)> = Vec::new();
        for &(t, ccw) in &scratch.included {
            let tri = self.triangles[t as usize];
            for k in 0..3 {
                let (i, j) = (tri[k], tri[(k + 1) % 3]);
                let neighbour = self.neighbours[t as usize][k];
                if neighbour != NONE {
                    let u = neighbour & !(1 << 31);
                    let same = neighbour >> 31 == 1;
                    if let Some(u_ccw) = scratch.orientation(u) {
                        // Both run the edge one way in projection when their orientations
                        // agree and they list it in opposite orders, or the other way round.
                        let opposite_in_projection = (ccw == u_ccw) != same;
                        if opposite_in_projection {
                            continue;
                        }
                    }
                }
                edges.push(if ccw { (i, j) } else { (j, i) });
            }
        }
        // Chain the directed edges into closed walks: every vertex has as many edges out as in,
        // so a walk from any edge returns to its start.
        edges.sort_unstable();
        let mut used = vec![false; edges.len()];
        let mut cursor: HashMap<u32, usize> = HashMap::new();
        for start in 0..edges.len() {
            if used[start] {
                continue;
            }
            let mut walk = Vec::new();
            let mut e = start;
            loop {
                used[e] = true;
                walk.push(project(p, self.vertices[edges[e].0 as usize]));
                let next = edges[e].1;
                if next == edges[start].0 {
                    break;
                }
                let from = *cursor
                    .entry(next)
                    .or_insert_with(|| edges.partition_point(|x| x.0 < next));
                let mut k = from;
                while k < edges.len() && edges[k].0 == next && used[k] {
                    k += 1;
                }
                if k >= edges.len() || edges[k].0 != next {
                    // Unreachable for a cycle; a broken one is dropped rather than guessed at.
                    walk.clear();
                    break;
                }
                cursor.insert(next, k);
                e = k;
            }
            if walk.len() >= 3 {
                scratch.contours.push(walk);
            }
        }
    }
}

/// Per-thread working memory of [`AnalyticCasters::visible_fraction`].
#[derive(Debug, Default)]
pub struct Scratch {
    /// Per triangle: the call that marked it (its generation) and its orientation.
    stamps: Vec<(u32, bool)>,
    generation: u32,
    included: Vec<(u32, bool)>,
    contours: Vec<Vec<P2>>,
}

impl Scratch {
    fn start(&mut self, triangles: usize) {
        if self.stamps.len() != triangles || self.generation == u32::MAX {
            self.stamps = vec![(0, false); triangles];
            self.generation = 0;
        }
        self.generation += 1;
        self.included.clear();
        self.contours.clear();
    }

    fn mark(&mut self, t: u32, ccw: bool) {
        self.stamps[t as usize] = (self.generation, ccw);
        self.included.push((t, ccw));
    }

    fn orientation(&self, t: u32) -> Option<bool> {
        let (g, ccw) = self.stamps[t as usize];
        (g == self.generation).then_some(ccw)
    }
}

/// `o` (light space) projected through `p` onto the light plane `z = 0` (`o.z < p.z`).
#[inline]
fn project(p: [f64; 3], o: [f64; 3]) -> P2 {
    let k = p[2] / (p[2] - o[2]);
    [p[0] + (o[0] - p[0]) * k, p[1] + (o[1] - p[1]) * k]
}

/// Twice the signed area of the triangle `a, b, c` (positive counter-clockwise).
#[inline]
fn cross(a: P2, b: P2, c: P2) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Twice the signed area of a closed polygon.
fn shoelace2(poly: &[P2]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

/// Whether the bounding box of `q` meets the open rectangle `(-a, a) x (-b, b)`.
fn meets_rect(q: &[P2; 3], a: f64, b: f64) -> bool {
    let (mut x0, mut x1, mut y0, mut y1) = (q[0][0], q[0][0], q[0][1], q[0][1]);
    for v in &q[1..] {
        x0 = x0.min(v[0]);
        x1 = x1.max(v[0]);
        y0 = y0.min(v[1]);
        y1 = y1.max(v[1]);
    }
    x0 < a && x1 > -a && y0 < b && y1 > -b
}

/// Whether the pyramid from `p` to the light `[-a, a] x [-b, b]`, within the depth slab, can
/// meet the box of `node`: at depth `z` the pyramid's section is the light scaled by
/// `s = 1 - z / p.z` towards `p`, so over the box's depths it lies within the box spanned by the
/// sections at the two ends (conservative: the box's own shape in depth is ignored).
fn pyramid_meets_box(p: [f64; 3], half: P2, slab: [f64; 2], node: &Node) -> bool {
    let z0 = node.lo[2].max(slab[0]);
    let z1 = node.hi[2].min(slab[1]);
    if z0 > z1 {
        return false;
    }
    let (s0, s1) = (1.0 - z1 / p[2], 1.0 - z0 / p[2]);
    (0..2).all(|axis| {
        let (c, h) = (p[axis], half[axis]);
        let lo = (c + (-h - c) * s0).min(c + (-h - c) * s1);
        let hi = (c + (h - c) * s0).max(c + (h - c) * s1);
        node.lo[axis] <= hi && node.hi[axis] >= lo
    })
}

/// One Sutherland-Hodgman pass: the closed polygon `poly` clipped to the half-space where
/// `inside` holds, `crossing(a, b)` giving the point where the edge from `a` (inside) or to `b`
/// crosses its boundary. Inside a convex clip region every point keeps its winding number.
fn clip_polygon<P: Copy>(
    poly: &[P],
    inside: impl Fn(&P) -> bool,
    crossing: impl Fn(P, P) -> P,
) -> Vec<P> {
    if poly.iter().all(&inside) {
        return poly.to_vec();
    }
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (cur, next) = (poly[i], poly[(i + 1) % poly.len()]);
        if inside(&cur) {
            out.push(cur);
        }
        if inside(&cur) != inside(&next) {
            out.push(crossing(cur, next));
        }
    }
    out
}

/// The triangle `v` clipped to the depths `slab[0] <= z <= slab[1]` (Sutherland-Hodgman).
fn clip_to_slab(v: &[[f64; 3]; 3], slab: [f64; 2]) -> Vec<[f64; 3]> {
    let at_depth = |bound: f64| {
        move |cur: [f64; 3], next: [f64; 3]| {
            let t = (bound - cur[2]) / (next[2] - cur[2]);
            [
                cur[0] + (next[0] - cur[0]) * t,
                cur[1] + (next[1] - cur[1]) * t,
                bound,
            ]
        }
    };
    let poly = clip_polygon(v, |o| o[2] >= slab[0], at_depth(slab[0]));
    clip_polygon(&poly, |o| o[2] <= slab[1], at_depth(slab[1]))
}

/// A closed polygon (any winding, self-intersecting or not) clipped to the rectangle
/// `[-a, a] x [-b, b]` (Sutherland-Hodgman against each side: inside the rectangle every point
/// keeps its winding number; the edges it adds along the sides enclose no area).
fn clip_to_rect(poly: &[P2], a: f64, b: f64) -> Vec<P2> {
    let mut poly = poly.to_vec();
    for (axis, bound, keep_below) in [(0, a, true), (0, -a, false), (1, b, true), (1, -b, false)] {
        let inside = |o: &P2| {
            if keep_below {
                o[axis] <= bound
            } else {
                o[axis] >= bound
            }
        };
        let crossing = |cur: P2, next: P2| {
            let t = (bound - cur[axis]) / (next[axis] - cur[axis]);
            let mut x = [
                cur[0] + (next[0] - cur[0]) * t,
                cur[1] + (next[1] - cur[1]) * t,
            ];
            x[axis] = bound;
            x
        };
        poly = clip_polygon(&poly, inside, crossing);
        if poly.is_empty() {
            break;
        }
    }
    poly
}

/// The region that `contours` (closed, each counter-clockwise where it adds coverage) wind
/// around at least once, as i_overlay's 64-bit engine gives it with the positive fill rule: outer
/// contours counter-clockwise, holes clockwise.
fn union_contours(contours: &[Vec<P2>]) -> Vec<Vec<P2>> {
    if contours.is_empty() {
        return Vec::new();
    }
    FloatOverlay::<P2, i64>::from_subj(contours)
        .overlay(OverlayRule::Subject, FillRule::Positive)
        .into_iter()
        .flatten()
        .collect()
}

/// Area of the region [`union_contours`] gives.
#[cfg(test)]
fn union_area(contours: &[Vec<P2>]) -> f64 {
    let twice: f64 = union_contours(contours).iter().map(|c| shoelace2(c)).sum();
    0.5 * twice.abs()
}

/// The form factor from a point `p` with unit normal `n` to the polygon `contour` of the light
/// plane `z = 0` (light space; `p.z > 0`): signed, positive for a counter-clockwise contour,
/// so the sum over a region's contours is the region's. Lambert's contour integral (Lambert
/// 1760; in graphics Baum et al. 1989, equation 3): `F = -(1 / 2 pi) sum_i theta_i n . g_i`,
/// with `theta_i` the angle the edge `v_i v_i+1` subtends at `p` and `g_i` the unit normal of
/// the plane through `p` and that edge. The contour is first clipped to the point's horizon
/// (`(q - p) . n > 0`); the integral holds for what lies above it.
pub fn polygon_form_factor(p: [f64; 3], n: [f64; 3], contour: &[[f64; 2]]) -> f64 {
    let above = clip_to_horizon(contour, p, n);
    let k = above.len();
    if k < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..k {
        let (q0, q1) = (above[i], above[(i + 1) % k]);
        let a = [q0[0] - p[0], q0[1] - p[1], -p[2]];
        let b = [q1[0] - p[0], q1[1] - p[1], -p[2]];
        let g = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let length = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        if length == 0.0 {
            continue;
        }
        let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let theta = length.atan2(dot);
        sum += theta * (n[0] * g[0] + n[1] * g[1] + n[2] * g[2]) / length;
    }
    -sum / (2.0 * std::f64::consts::PI)
}

/// The part of `contour` (on the plane `z = 0`) above the horizon of `p` with normal `n`:
/// where `(q - p) . n > 0` (Sutherland-Hodgman against that line, which keeps the winding
/// number on its inside).
fn clip_to_horizon(contour: &[P2], p: [f64; 3], n: [f64; 3]) -> Vec<P2> {
    let height = |q: &P2| (q[0] - p[0]) * n[0] + (q[1] - p[1]) * n[1] - p[2] * n[2];
    let crossing = |q0: P2, q1: P2| {
        let (h0, h1) = (height(&q0), height(&q1));
        let t = h0 / (h0 - h1);
        [q0[0] + (q1[0] - q0[0]) * t, q0[1] + (q1[1] - q0[1]) * t]
    };
    clip_polygon(contour, |q| height(q) > 0.0, crossing)
}

/// Analytic per-pixel visibility of `scene` (row-major, like `positions`), in parallel with
/// rayon: 1.0 where the position is `None` or the pixel is not a receiver, else
/// [`AnalyticCasters::visible_fraction`] of the light-space point. `Err` when the light has no
/// area.
pub fn visibility_image(
    scene: &Scene,
    positions: &[Option<Vec3>],
    receiver_mask: &[bool],
) -> Result<Vec<f32>, AnalyticError> {
    let seen = light_seen_image(scene, positions, None, receiver_mask, None)?;
    Ok(seen.iter().map(|s| s.visibility as f32).collect())
}

/// [`AnalyticCasters::light_seen`] at every pixel of `scene` (row-major, like `positions`), in
/// parallel with rayon; `normals` are world-space unit normals per pixel (the G-buffer's; without
/// them the form factors are 0). Where the position is `None` or the pixel is not a receiver:
/// visibility 1 and form factors 0. `control` (optional) counts the receiver pixels done as a
/// build of "exact-answer pixels" (a progress bar) and stops the work when cancelled. `Err` when
/// the light has no area or the work was cancelled.
pub fn light_seen_image(
    scene: &Scene,
    positions: &[Option<Vec3>],
    normals: Option<&[Vec3]>,
    receiver_mask: &[bool],
    control: Option<&BuildControl>,
) -> Result<Vec<LightSeen>, AnalyticError> {
    let casters = AnalyticCasters::new(scene, &scene.light)?;
    let cancelled = || control.is_some_and(BuildControl::is_cancelled);
    if let Some(control) = control {
        let receivers = receiver_mask.iter().filter(|r| **r).count();
        control.start(
            receivers.min(u32::MAX as usize) as u32,
            "exact-answer pixels",
        );
    }
    let view = scene.light.view();
    let off_receivers = LightSeen {
        visibility: 1.0,
        ..LightSeen::DARK
    };
    let seen: Vec<LightSeen> = positions
        .par_iter()
        .enumerate()
        .map_init(Scratch::default, |scratch, (i, p)| match p {
            Some(p) if receiver_mask.get(i).copied().unwrap_or(false) => {
                if cancelled() {
                    return LightSeen::DARK;
                }
                let point = view.transform_point3(*p);
                let normal = normals
                    .and_then(|n| n.get(i))
                    .map(|n| view.transform_vector3(*n));
                let seen = casters.light_seen(point, normal, scratch);
                if let Some(control) = control {
                    control.done.fetch_add(1, Ordering::Relaxed);
                }
                seen
            }
            _ => off_receivers,
        })
        .collect();
    if let Some(control) = control {
        control.finish();
    }
    if cancelled() {
        return Err(AnalyticError::Cancelled);
    }
    Ok(seen)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Twice the area of what `union_area` is given, summed: the union when nothing overlaps.
    fn area_sum(contours: &[Vec<P2>]) -> f64 {
        contours.iter().map(|c| 0.5 * shoelace2(c)).sum()
    }

    /// The triangle (0, 0), (1, 0), (1, 1e-3 * 7) cut into thousands of slivers fanning from
    /// its first corner: each sliver is nearly collinear (its angle about 1.4e-6 rad) and every
    /// neighbour shares an edge. Their union is the triangle, to rounding.
    #[test]
    fn the_union_of_thousands_of_nearly_collinear_slivers_is_their_triangle() {
        let n = 5000;
        let top = 7e-3;
        let slivers: Vec<Vec<P2>> = (0..n)
            .map(|k| {
                let y0 = top * k as f64 / n as f64;
                let y1 = top * (k + 1) as f64 / n as f64;
                vec![[0.0, 0.0], [1.0, y0], [1.0, y1]]
            })
            .collect();
        let area = union_area(&slivers);
        let expected = 0.5 * top;
        assert!(
            ((area - expected) / expected).abs() < 1e-12,
            "{area} vs {expected}"
        );
        assert!(((area_sum(&slivers) - expected) / expected).abs() < 1e-12);
        // The same slivers twice, and reversed ones (clockwise: no coverage with the positive
        // rule) do not change it.
        let mut doubled = slivers.clone();
        doubled.extend(slivers.iter().cloned());
        let area2 = union_area(&doubled);
        assert!(((area2 - expected) / expected).abs() < 1e-12, "{area2}");
    }

    /// Thousands of tiny triangles scattered over the unit square, overlapping at random: the
    /// union never exceeds the sum of their areas or the square, and equals the sum where they
    /// are spaced apart.
    #[test]
    fn the_union_of_scattered_tiny_triangles_is_bounded_and_exact_when_disjoint() {
        let mut rng = crate::SplitMix64(7);
        let mut next = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        let tiny: Vec<Vec<P2>> = (0..3000)
            .map(|_| {
                let (x, y) = (next(), next());
                vec![[x, y], [x + 1e-3 * next(), y], [x, y + 1e-3 * next()]]
            })
            .collect();
        let area = union_area(&tiny);
        assert!(
            area > 0.0 && area <= area_sum(&tiny) * (1.0 + 1e-12) && area < 1.0,
            "{area}"
        );
        // On a 60 x 60 grid of cells 1/60 wide, one triangle per cell: disjoint.
        let spaced: Vec<Vec<P2>> = (0..3600)
            .map(|k| {
                let (x, y) = ((k % 60) as f64 / 60.0, (k / 60) as f64 / 60.0);
                let s = 1e-3 * (1.0 + next());
                vec![[x, y], [x + s, y + 1e-9], [x, y + s]]
            })
            .collect();
        let (area, sum) = (union_area(&spaced), area_sum(&spaced));
        assert!(((area - sum) / sum).abs() < 1e-12, "{area} vs {sum}");
    }

    /// Clipping to the rectangle keeps the part inside; a polygon wholly outside vanishes.
    #[test]
    fn clip_to_rect_keeps_the_inside() {
        let square = vec![[-2.0, -2.0], [0.5, -2.0], [0.5, 0.5], [-2.0, 0.5]];
        let clipped = clip_to_rect(&square, 1.0, 1.0);
        assert!(
            (0.5 * shoelace2(&clipped) - 2.25).abs() < 1e-15,
            "{clipped:?}"
        );
        let outside = vec![[2.0, 2.0], [3.0, 2.0], [3.0, 3.0]];
        assert!(clip_to_rect(&outside, 1.0, 1.0).len() < 3);
    }

    /// A light of no area is refused with a line that says what is used instead.
    #[test]
    fn a_light_without_area_is_refused() {
        let scene = Scene {
            materials: Vec::new(),
            textures: Vec::new(),
            name: "t".into(),
            meshes: Vec::new(),
            instances: Vec::new(),
            light: AreaLight {
                width: 0.0,
                ..AreaLight::default()
            },
            camera: softshadow_core::Camera::default(),
        };
        let error = AnalyticCasters::new(&scene, &scene.light).unwrap_err();
        assert!(error.to_string().contains("positive area"), "{error}");
    }

    /// Lambert's closed form for a point at height `h` over a corner of an `x` by `y`
    /// rectangle in a parallel plane, facing it (signed: odd in `x` and in `y`).
    fn corner_form_factor(x: f64, y: f64, h: f64) -> f64 {
        let (x, y) = (x / h, y / h);
        let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
    }

    /// The closed form for the rectangle `[x0, x1] x [y0, y1]` of the plane `z = 0` from
    /// `p` facing it, by inclusion and exclusion of corner rectangles.
    fn rect_form_factor(r: [f64; 4], p: [f64; 3]) -> f64 {
        let g = |x: f64, y: f64| corner_form_factor(x - p[0], y - p[1], p[2]);
        g(r[1], r[3]) - g(r[0], r[3]) - g(r[1], r[2]) + g(r[0], r[2])
    }

    /// The contour integral equals Lambert's closed form for an unoccluded rectangle seen from
    /// points under it, beside it and far off, facing it; a point facing away sees nothing.
    #[test]
    fn the_contour_integral_equals_the_closed_form_for_a_rectangle() {
        let light = [[-0.5, -0.3], [0.5, -0.3], [0.5, 0.3], [-0.5, 0.3]];
        let facing = [0.0, 0.0, -1.0];
        for p in [
            [0.0, 0.0, 1.0],
            [0.2, -0.1, 0.3],
            [2.0, 1.5, 0.7],
            [0.5, 0.3, 4.0],
        ] {
            let integral = polygon_form_factor(p, facing, &light);
            let closed = rect_form_factor([-0.5, 0.5, -0.3, 0.3], p);
            assert!(
                (integral - closed).abs() < 1e-12,
                "{p:?}: {integral} vs {closed}"
            );
            assert!(closed > 0.0);
            assert_eq!(polygon_form_factor(p, [0.0, 0.0, 1.0], &light), 0.0);
        }
        // A normal along the plane, at a point under the light's middle: half the light is
        // above its horizon, and the form factor of a perpendicular rectangle is known too:
        // from a point at height h over one end of its side l on the planes' common line, with
        // w its side away from that line, F = (1 / 2 pi) (atan(1 / Y) - Y / sqrt(X^2 + Y^2)
        // atan(1 / sqrt(X^2 + Y^2))), X = w / l, Y = h / l (Howell's catalogue of configuration factors).
        let p = [0.0, 0.0, 1.0];
        let along = polygon_form_factor(p, [1.0, 0.0, 0.0], &light);
        let perpendicular = |w: f64, l: f64, h: f64| {
            let (x, y) = (w / l, h / l);
            let r = (x * x + y * y).sqrt();
            ((1.0 / y).atan() - y / r * (1.0 / r).atan()) / (2.0 * std::f64::consts::PI)
        };
        // The half x > 0 is two rectangles, l = 0.3 along the common line on either side of the
        // foot, w = 0.5 away from it.
        let closed = 2.0 * perpendicular(0.5, 0.3, 1.0);
        assert!((along - closed).abs() < 1e-12, "{along} vs {closed}");
    }

    /// A square occluder parallel to the light: the irradiance from the visible part equals the
    /// closed form of the light minus that of the occluder's projection clipped to the light,
    /// within 1e-9; the unoccluded irradiance that of the light; a receiver facing away from the
    /// whole light has irradiance 0 whatever its visibility.
    #[test]
    fn the_irradiance_under_a_parallel_occluder_equals_the_closed_form() {
        let square = softshadow_core::Mesh {
            texcoords: Vec::new(),
            name: "square".into(),
            positions: vec![
                Vec3::new(-0.2, 2.0, -0.2),
                Vec3::new(0.2, 2.0, -0.2),
                Vec3::new(0.2, 2.0, 0.2),
                Vec3::new(-0.2, 2.0, 0.2),
            ],
            normals: Vec::new(),
            indices: vec![0, 1, 2, 0, 2, 3],
        };
        let scene = Scene {
            materials: Vec::new(),
            textures: Vec::new(),
            name: "t".into(),
            meshes: vec![square],
            instances: vec![softshadow_core::Instance::new(
                0,
                softshadow_core::glam::Mat4::from_translation(Vec3::new(0.1, 0.0, 0.05)),
            )],
            light: AreaLight::default(),
            camera: softshadow_core::Camera::default(),
        };
        let casters = AnalyticCasters::new(&scene, &scene.light).unwrap();
        let light = &scene.light;
        let up = light.view().transform_vector3(Vec3::Y);
        let corners = [Vec3::new(-0.1, 2.0, -0.15), Vec3::new(0.3, 2.0, 0.25)]
            .map(|c| light.to_light_space(c).as_dvec3());
        let mut scratch = Scratch::default();
        let mut penumbra = 0;
        for k in 0..40 {
            let world = Vec3::new(-1.0 + 0.05 * k as f32, 0.0, 0.3 - 0.02 * k as f32);
            let p = light.to_light_space(world);
            let seen = casters.light_seen(p, Some(up), &mut scratch);
            let pd = p.as_dvec3();
            let project = |o: softshadow_core::glam::DVec3| {
                let t = pd.z / (pd.z - o.z);
                [pd.x + (o.x - pd.x) * t, pd.y + (o.y - pd.y) * t]
            };
            let (q0, q1) = (project(corners[0]), project(corners[1]));
            let (a, b) = (0.5, 0.5);
            let shadow = [
                q0[0].min(q1[0]).max(-a),
                q0[0].max(q1[0]).min(a),
                q0[1].min(q1[1]).max(-b),
                q0[1].max(q1[1]).min(b),
            ];
            let whole = rect_form_factor([-a, a, -b, b], [pd.x, pd.y, pd.z]);
            let hidden = if shadow[0] < shadow[1] && shadow[2] < shadow[3] {
                rect_form_factor(shadow, [pd.x, pd.y, pd.z])
            } else {
                0.0
            };
            assert!((seen.unoccluded - whole).abs() < 1e-9, "{world}");
            assert!(
                (seen.irradiance - (whole - hidden)).abs() < 1e-9,
                "{world}: {seen:?}"
            );
            penumbra += (seen.visibility > 0.0 && seen.visibility < 1.0) as usize;
            let away = casters.light_seen(p, Some(-up), &mut scratch);
            assert_eq!((away.irradiance, away.unoccluded), (0.0, 0.0));
            assert_eq!(away.visibility, seen.visibility);
        }
        assert!(penumbra >= 5, "{penumbra} penumbra points");
    }
}
