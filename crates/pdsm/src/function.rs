//! Attenuation functions along one PDSM ray: events merged into a step function, its
//! piecewise-linear compression (Lokovic & Veach 2000, section 4.2; St-Amour et al. 2005,
//! section 3.2 and Fig. 5) and its evaluation (section 4).
//!
//! A function is a list of vertices `[depth, visibility]` sorted by depth, interpolated linearly
//! between neighbours and constant beyond both ends; an empty list is "lit everywhere" (1.0).
//! Two vertices at the same depth are a step (the value jumps there; at the step depth itself the
//! function takes the value after the jump).

/// One visibility event along a ray: at `depth` the number of shadow maps that see the ray
/// point shadowed changes by `delta` (+1 entry, -1 exit; section 3.1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    /// Light-space depth of the event.
    pub depth: f32,
    /// Change in the number of maps that see the point shadowed.
    pub delta: i32,
}

/// Sorts `events`, merges the ones closer than `tolerance(depth)` (the shadow maps' depth
/// resolution, section 3.1, step 6) and returns the step function `V = 1 - shadowed / k` as
/// vertex pairs (value before, value after) at each merged event whose net change is not zero,
/// and the number of such events.
pub fn step_function(
    events: &mut [Event],
    samples: u32,
    tolerance: impl Fn(f32) -> f32,
    out: &mut Vec<[f32; 2]>,
) -> usize {
    out.clear();
    events.sort_by(|a, b| a.depth.total_cmp(&b.depth));
    let k = samples.max(1) as f32;
    let mut shadowed = 0i32;
    let mut merged_events = 0;
    let mut i = 0;
    while i < events.len() {
        let start = events[i].depth;
        let limit = start + tolerance(start);
        let (mut delta, mut weighted, mut weight) = (0i32, 0.0f64, 0.0f64);
        while i < events.len() && events[i].depth <= limit {
            delta += events[i].delta;
            weighted += events[i].depth as f64;
            weight += 1.0;
            i += 1;
        }
        if delta == 0 {
            continue;
        }
        let depth = (weighted / weight) as f32;
        let before = 1.0 - shadowed as f32 / k;
        shadowed = (shadowed + delta).clamp(0, samples as i32);
        let after = 1.0 - shadowed as f32 / k;
        out.push([depth, before]);
        out.push([depth, after]);
        merged_events += 1;
    }
    merged_events
}

/// Compresses `raw` to a piecewise-linear function that stays within `max_error` of it at every
/// depth: from the current origin, extend the segment over as many vertices as the range of
/// slopes through all their `[v - e, v + e]` windows allows, end it at the last vertex that fit
/// (slope in the middle of the range), and start the next segment there (Lokovic & Veach 2000,
/// section 4.2). A step larger than `max_error` at the origin's depth becomes a vertical step.
pub fn compress(raw: &[[f32; 2]], max_error: f32, out: &mut Vec<[f32; 2]>) {
    out.clear();
    let Some(&first) = raw.first() else {
        return;
    };
    out.push(first);
    let [mut z0, mut v0] = first;
    let (mut lo, mut hi) = (f32::NEG_INFINITY, f32::INFINITY);
    let mut last_z = z0;
    let mut i = 1;
    while i < raw.len() {
        let [z, v] = raw[i];
        let dz = z - z0;
        if dz <= 0.0 {
            // At the origin's depth: a step, kept as a vertical one when it exceeds the error.
            if (v - v0).abs() > max_error {
                out.push([z0, v]);
                v0 = v;
            }
            i += 1;
            continue;
        }
        let (new_lo, new_hi) = (
            lo.max((v - max_error - v0) / dz),
            hi.min((v + max_error - v0) / dz),
        );
        if new_lo <= new_hi {
            (lo, hi, last_z) = (new_lo, new_hi, z);
            i += 1;
            continue;
        }
        // Vertex i does not fit: end the segment at the last one that did and retry i from there.
        let end = v0 + 0.5 * (lo + hi) * (last_z - z0);
        out.push([last_z, end]);
        (z0, v0) = (last_z, end);
        (lo, hi) = (f32::NEG_INFINITY, f32::INFINITY);
    }
    if last_z > z0 {
        out.push([last_z, v0 + 0.5 * (lo + hi) * (last_z - z0)]);
    }
}

/// The function's value at `depth` (section 4, Algorithm 2 step 4); at a step, the value after it.
pub fn evaluate(function: &[[f32; 2]], depth: f32) -> f32 {
    let Some(first) = function.first() else {
        return 1.0;
    };
    if depth < first[0] {
        return first[1];
    }
    for pair in function.windows(2) {
        let ([z0, v0], [z1, v1]) = (pair[0], pair[1]);
        if depth < z1 {
            return v0 + (depth - z0) / (z1 - z0) * (v1 - v0);
        }
    }
    function[function.len() - 1][1]
}

/// The limit of the function approaching `depth` from below (at a step: the value before it).
pub fn evaluate_left(function: &[[f32; 2]], depth: f32) -> f32 {
    let Some(first) = function.first() else {
        return 1.0;
    };
    if depth <= first[0] {
        return first[1];
    }
    for pair in function.windows(2) {
        let ([z0, v0], [z1, v1]) = (pair[0], pair[1]);
        if depth <= z1 {
            return v0 + (depth - z0) / (z1 - z0) * (v1 - v0);
        }
    }
    function[function.len() - 1][1]
}

/// Largest difference between `compressed` and `raw` at every depth where `raw` has a vertex,
/// from both sides of each step (the difference is linear in between, so this is the maximum
/// over all depths).
pub fn max_deviation(raw: &[[f32; 2]], compressed: &[[f32; 2]]) -> f32 {
    let mut worst = 0.0f32;
    for &[z, _] in raw {
        let left = (evaluate_left(raw, z) - evaluate_left(compressed, z)).abs();
        let right = (evaluate(raw, z) - evaluate(compressed, z)).abs();
        worst = worst.max(left).max(right);
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    fn events(list: &[(f32, i32)]) -> Vec<Event> {
        list.iter()
            .map(|&(depth, delta)| Event { depth, delta })
            .collect()
    }

    #[test]
    fn events_sum_to_a_step_function_and_close_ones_merge() {
        let mut e = events(&[
            (2.0, 1),
            (1.0, 1),
            (1.0005, 1),
            (3.0, -1),
            (3.0, -1),
            (4.0, -1),
        ]);
        let mut f = Vec::new();
        let n = step_function(&mut e, 4, |z| 1e-3 * z, &mut f);
        // 1.0 and 1.0005 merge (+2); the two exits at 3.0 merge (-2).
        assert_eq!(n, 4);
        assert_eq!(evaluate(&f, 0.5), 1.0);
        assert_eq!(evaluate(&f, 1.5), 0.5);
        assert_eq!(evaluate(&f, 2.5), 0.25);
        assert_eq!(evaluate(&f, 3.5), 0.75);
        assert_eq!(evaluate(&f, 9.0), 1.0);
        assert_eq!(evaluate_left(&f, 2.0), 0.5);
        // Entry and exit at the same depth cancel: no event.
        let mut e = events(&[(1.0, 1), (1.0, -1)]);
        assert_eq!(step_function(&mut e, 4, |_| 0.0, &mut f), 0);
        assert!(f.is_empty());
    }

    #[test]
    fn compression_stays_within_the_error_and_drops_vertices() {
        // A staircase of 64 steps of 1/64 from depth 1 to 2: a ramp within 0.02.
        let mut e: Vec<Event> = (0..64)
            .map(|i| Event {
                depth: 1.0 + i as f32 / 64.0,
                delta: 1,
            })
            .collect();
        let mut raw = Vec::new();
        step_function(&mut e, 64, |_| 0.0, &mut raw);
        let mut compressed = Vec::new();
        for max_error in [0.0, 0.01, 0.02, 0.1] {
            compress(&raw, max_error, &mut compressed);
            let deviation = max_deviation(&raw, &compressed);
            assert!(
                deviation <= max_error + 1e-6,
                "{max_error}: deviation {deviation}"
            );
        }
        compress(&raw, 0.02, &mut compressed);
        // 128 raw vertices; a 1/64 staircase within 0.02 is one ramp plus its ends.
        assert!(compressed.len() <= 4, "{compressed:?}");
        // A hard step larger than the error stays a step.
        let raw = vec![[1.0, 1.0], [1.0, 0.0]];
        compress(&raw, 0.05, &mut compressed);
        assert_eq!(max_deviation(&raw, &compressed), 0.0);
        assert_eq!(evaluate(&compressed, 1.0), 0.0);
        assert_eq!(evaluate(&compressed, 0.9), 1.0);
    }

    #[test]
    fn evaluation_of_empty_and_single_vertex_functions() {
        assert_eq!(evaluate(&[], 3.0), 1.0);
        assert_eq!(evaluate(&[[1.0, 0.25]], 0.0), 0.25);
        assert_eq!(evaluate(&[[1.0, 0.25]], 2.0), 0.25);
    }
}
