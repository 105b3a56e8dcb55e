//! The CPU part of the construction (St-Amour et al. 2005, section 3.1, Algorithm 1 steps 3-6):
//! every PDSM texel's ray scan-converted in every shadow map, shadowed intervals turned into
//! +-1/k events, summed, merged and compressed. Rayon runs over PDSM rows.

use std::sync::atomic::Ordering;

use rayon::prelude::*;
use softshadow_core::{glam::Vec2, BuildControl, SlopeFrustum};

use crate::function::{self, Event};

/// One shadow map read back from the GPU: light-space depth per texel (row 0 at `t_max`),
/// `f32::INFINITY` where no caster was drawn.
pub struct SampleMap {
    /// The map's window and depth range.
    pub frustum: SlopeFrustum,
    /// Light-space depth per texel, row-major.
    pub depth: Vec<f32>,
}

/// The k shadow maps of the light samples, all `size`².
pub struct SampleMaps {
    /// Edge of every map in texels.
    pub size: u32,
    /// One map per light sample.
    pub maps: Vec<SampleMap>,
}

impl SampleMaps {
    /// Largest slope extent of one texel over the maps (their depth resolution per unit depth).
    pub fn max_texel_slope(&self) -> f32 {
        self.maps
            .iter()
            .map(|m| (m.frustum.s_max - m.frustum.s_min) / self.size as f32)
            .fold(0.0, f32::max)
    }
}

/// The compressed PDSM: the Fig. 6 index (`offsets[i]..offsets[i + 1]` are texel i's vertices)
/// and data (`[depth, visibility]` vertices, see [`crate::function`]).
#[derive(Clone, Debug, PartialEq)]
pub struct PdsmData {
    /// Edge in texels.
    pub size: u32,
    /// Window from the light centre (eye = 0) and the depth range of the rays.
    pub frustum: SlopeFrustum,
    /// Start of each texel's vertices in `vertices` (one more entry than texels).
    pub offsets: Vec<u32>,
    /// `[depth, visibility]` vertices of every texel's function.
    pub vertices: Vec<[f32; 2]>,
    /// What the build measured.
    pub stats: BuildStats,
}

/// Event counts per texel before and after compression, and the largest compression error
/// measured against the uncompressed function.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Mean events per texel before compression.
    pub events_mean: f64,
    /// Most events in one texel.
    pub events_max: u32,
    /// Mean vertices per texel after compression.
    pub vertices_mean: f64,
    /// Most vertices in one texel.
    pub vertices_max: u32,
    /// Largest difference between the compressed and the exact function.
    pub max_compression_error: f32,
}

/// Why a build stopped without a result.
#[derive(Debug, PartialEq, Eq)]
pub struct Cancelled;

/// Slopes `(s, t)` of the centre of PDSM texel `(column, row)`.
pub fn texel_slope(frustum: &SlopeFrustum, size: u32, column: u32, row: u32) -> Vec2 {
    let n = size as f32;
    Vec2::new(
        frustum.s_min + (column as f32 + 0.5) / n * (frustum.s_max - frustum.s_min),
        frustum.t_max - (row as f32 + 0.5) / n * (frustum.t_max - frustum.t_min),
    )
}

/// One PDSM row: vertex count per texel, the vertices, the row's stats and its event count.
type RowResult = (Vec<u32>, Vec<[f32; 2]>, BuildStats, u64);

/// Builds the PDSM for the `frustum` window at `size`², with events merged within
/// `merge_fraction * depth` and functions compressed within `max_error`. Counts finished rows in
/// `control.done` and stops at the next row once `control.cancel` is set.
pub fn build(
    maps: &SampleMaps,
    frustum: &SlopeFrustum,
    size: u32,
    max_error: f32,
    control: &BuildControl,
) -> Result<PdsmData, Cancelled> {
    // Events closer than half a shadow-map texel footprint at their depth are merged (section
    // 3.1: "close to the resolution of the shadow map"), at most 0.1 % of the depth: a caster next
    // to the light widens the maps' windows so much that a texel footprint spans whole depth
    // ranges (stiff-near-light).
    let merge_fraction = (0.5 * maps.max_texel_slope()).min(1e-3);
    let samples = maps.maps.len() as u32;
    let rows: Vec<RowResult> = (0..size)
        .into_par_iter()
        .map(|row| {
            if control.cancel.load(Ordering::Relaxed) {
                return Err(Cancelled);
            }
            let mut events = Vec::new();
            let mut intervals = Vec::new();
            let (mut raw, mut compressed) = (Vec::new(), Vec::new());
            let mut counts = Vec::with_capacity(size as usize);
            let mut data = Vec::new();
            let mut stats = BuildStats::default();
            let mut event_sum = 0u64;
            for column in 0..size {
                let slope = texel_slope(frustum, size, column, row);
                events.clear();
                for map in &maps.maps {
                    intervals.clear();
                    shadowed_intervals(
                        map,
                        maps.size,
                        slope,
                        frustum.near,
                        frustum.far,
                        &mut intervals,
                    );
                    for &(start, end) in &intervals {
                        events.push(Event {
                            depth: start,
                            delta: 1,
                        });
                        if end.is_finite() {
                            events.push(Event {
                                depth: end,
                                delta: -1,
                            });
                        }
                    }
                }
                let merged =
                    function::step_function(&mut events, samples, |z| merge_fraction * z, &mut raw);
                function::compress(&raw, max_error, &mut compressed);
                stats.max_compression_error = stats
                    .max_compression_error
                    .max(function::max_deviation(&raw, &compressed));
                stats.events_max = stats.events_max.max(merged as u32);
                stats.vertices_max = stats.vertices_max.max(compressed.len() as u32);
                event_sum += merged as u64;
                counts.push(compressed.len() as u32);
                data.extend_from_slice(&compressed);
            }
            control.done.fetch_add(1, Ordering::Relaxed);
            Ok((counts, data, stats, event_sum))
        })
        .collect::<Result<_, _>>()?;
    let texels = (size as usize * size as usize).max(1);
    let mut offsets = Vec::with_capacity(texels + 1);
    let mut vertices = Vec::new();
    let mut stats = BuildStats::default();
    let mut event_sum = 0u64;
    offsets.push(0u32);
    for (counts, data, row_stats, row_events) in rows {
        for count in counts {
            let last = *offsets.last().expect("starts with 0");
            offsets.push(last + count);
        }
        vertices.extend_from_slice(&data);
        stats.events_max = stats.events_max.max(row_stats.events_max);
        stats.vertices_max = stats.vertices_max.max(row_stats.vertices_max);
        stats.max_compression_error = stats
            .max_compression_error
            .max(row_stats.max_compression_error);
        event_sum += row_events;
    }
    stats.events_mean = event_sum as f64 / texels as f64;
    stats.vertices_mean = vertices.len() as f64 / texels as f64;
    Ok(PdsmData {
        size,
        frustum: *frustum,
        offsets,
        vertices,
        stats,
    })
}

/// The shadowed depth intervals `[start, end)` of the ray from the light centre at slopes
/// `ray` between depths `near` and `far`, in one shadow map (sorted, disjoint; `end` is infinite
/// when the ray is still shadowed at `far`).
///
/// The ray projects to a straight segment in the map: a point at depth z has map slopes
/// `ray - eye / z`, linear in w = 1 / z. The segment is clipped to the map (outside it no caster
/// is seen, so the ray is lit) and scan-converted with the mid-point rule (Fig. 3): one texel per
/// column of the major axis, the row taken at the column's middle. In each texel the ray spans
/// depths `[z_in, z_out]`; it is shadowed from `max(z_map, z_in)` on when the map depth
/// `z_map < z_out`: the map depth where it lies inside the texel's span (Fig. 4a), the ray's own
/// depth where the map's is in front of it (Fig. 4b), and an exit at the boundary with the
/// previous texel (Fig. 4c). A ray inside a single texel only enters.
pub fn shadowed_intervals(
    map: &SampleMap,
    map_size: u32,
    ray: Vec2,
    near: f32,
    far: f32,
    out: &mut Vec<(f32, f32)>,
) {
    let f = &map.frustum;
    let m = map_size as f32;
    let scale_u = m / (f.s_max - f.s_min);
    let scale_v = m / (f.t_max - f.t_min);
    // Texel coordinates as a + b * w.
    let u = ((ray.x - f.s_min) * scale_u, -f.eye.x * scale_u);
    let v = ((f.t_max - ray.y) * scale_v, f.eye.y * scale_v);
    let (w_far, w_near) = (1.0 / far, 1.0 / near);
    let (mut w_lo, mut w_hi) = (w_far, w_near);
    for (a, b) in [u, v] {
        if b == 0.0 {
            if !(0.0..m).contains(&a) {
                return;
            }
        } else {
            let (w0, w1) = ((0.0 - a) / b, (m - a) / b);
            w_lo = w_lo.max(w0.min(w1));
            w_hi = w_hi.min(w0.max(w1));
        }
    }
    if w_lo >= w_hi {
        return;
    }
    let reaches_far = w_lo <= w_far;
    let texel = |column: f32, row: f32| -> f32 {
        let c = (column.floor() as i64).clamp(0, map_size as i64 - 1) as usize;
        let r = (row.floor() as i64).clamp(0, map_size as i64 - 1) as usize;
        map.depth[r * map_size as usize + c]
    };
    let mut push = |start: f32, end: f32| match out.last_mut() {
        Some(last) if last.1 >= start => last.1 = last.1.max(end),
        _ => out.push((start, end)),
    };
    // The major axis moves faster along the segment; the ray is traversed near to far (w falls).
    let u_major = u.1.abs() >= v.1.abs();
    let (major, minor) = if u_major { (u, v) } else { (v, u) };
    let z_end = if reaches_far {
        f32::INFINITY
    } else {
        1.0 / w_lo
    };
    if major.1 == 0.0 {
        // The light sample is the PDSM's own centre of projection: one texel for the whole ray.
        let z_map = texel(u.0, v.0);
        if z_map < 1.0 / w_lo {
            push(z_map.max(1.0 / w_hi), z_end);
        }
        return;
    }
    let p_start = major.0 + major.1 * w_hi;
    let p_end = major.0 + major.1 * w_lo;
    let last_cell = m - 1.0;
    let first = p_start.floor().clamp(0.0, last_cell);
    let last = p_end.floor().clamp(0.0, last_cell);
    let step = if p_end >= p_start { 1.0 } else { -1.0 };
    let columns = ((last - first) * step) as u32 + 1;
    let w_at = |p: f32| (p - major.0) / major.1;
    for n in 0..columns {
        let c = first + step * n as f32;
        let p_in = if n == 0 {
            p_start
        } else if step > 0.0 {
            c
        } else {
            c + 1.0
        };
        let is_last = n + 1 == columns;
        let p_out = if is_last {
            p_end
        } else if step > 0.0 {
            c + 1.0
        } else {
            c
        };
        // Mid-point rule: the row at the middle of the column (clamped to the segment).
        let p_mid = (c + 0.5).clamp(p_in.min(p_out), p_in.max(p_out));
        let q = minor.0 + minor.1 * w_at(p_mid);
        let z_map = if u_major { texel(c, q) } else { texel(q, c) };
        let z_in = 1.0 / w_at(p_in);
        let z_out = 1.0 / w_at(p_out);
        if z_map < z_out {
            // Still shadowed where the scan ends at `far`: shadowed beyond it too.
            push(z_map.max(z_in), if is_last { z_end } else { z_out });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map from `eye` whose window is [-1, 1]² with every texel at depth `z`, except those in
    /// `holes` (no caster).
    fn flat_map(eye: Vec2, size: u32, z: f32) -> SampleMap {
        SampleMap {
            frustum: SlopeFrustum {
                eye,
                s_min: -1.0,
                s_max: 1.0,
                t_min: -1.0,
                t_max: 1.0,
                near: 0.5,
                far: 10.0,
            },
            depth: vec![z; (size * size) as usize],
        }
    }

    #[test]
    fn a_plane_in_front_of_the_centre_ray_shadows_it_from_its_depth_on() {
        let map = flat_map(Vec2::ZERO, 16, 2.0);
        let mut out = Vec::new();
        shadowed_intervals(&map, 16, Vec2::new(0.1, 0.1), 1.0, 5.0, &mut out);
        assert_eq!(out, vec![(2.0, f32::INFINITY)]);
    }

    #[test]
    fn a_ray_leaving_the_map_window_is_lit_from_there_on() {
        // Eye at x = 1: map slope = ray slope - 1 / z. The ray at slope 1.5 is inside the map's
        // window ([-1, 1]) while 1.5 - 1 / z <= 1, i.e. up to z = 2, and lit beyond it.
        let map = flat_map(Vec2::new(1.0, 0.0), 32, 1.5);
        let mut out = Vec::new();
        shadowed_intervals(&map, 32, Vec2::new(1.5, 0.0), 1.0, 5.0, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert_eq!(out[0].0, 1.5);
        assert!((out[0].1 - 2.0).abs() < 1e-4, "{out:?}");
        // Entirely in front of the map depth: lit.
        out.clear();
        shadowed_intervals(&map, 32, Vec2::new(0.0, 0.0), 1.0, 1.4, &mut out);
        assert!(out.is_empty(), "{out:?}");
    }

    #[test]
    fn an_occluder_edge_gives_entry_at_its_depth_and_exit_where_the_ray_passes_it() {
        // Half-plane occluder at depth 1 over map slopes s < 0, seen from eye x = 0.5: a point at
        // depth z > 1 on the ray of slope 0 has map slope -0.5 / z, always < 0: shadowed from 1.
        // The ray of slope 0.3 has map slope 0.3 - 0.5 / z < 0 for z < 5/3: shadowed on [1, 5/3).
        let size = 256;
        let mut map = flat_map(Vec2::new(0.5, 0.0), size, f32::INFINITY);
        for row in 0..size {
            for column in 0..size / 2 {
                map.depth[(row * size + column) as usize] = 1.0;
            }
        }
        let mut out = Vec::new();
        shadowed_intervals(&map, size, Vec2::new(0.3, 0.0), 0.6, 8.0, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert_eq!(out[0].0, 1.0);
        // Exit within one texel column (slope 2 / 256) of 5/3: |dz| = z^2 / 0.5 * ds ~ 0.043.
        assert!((out[0].1 - 5.0 / 3.0).abs() < 0.05, "{out:?}");
    }
}
