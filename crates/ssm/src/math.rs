//! The geometry of soft shadow maps (Atty et al. 2006, sections 3.2-3.4 and appendix A) on the
//! CPU, in light space (light centre at the origin facing +z, light `[-a, a] x [-b, b]` in z = 0)
//! and slope space (`s = x / z`, `t = y / z` seen from the light centre). The shaders
//! (`shaders/ssm/scatter.wgsl`) compute the same quantities; these functions pin them down in unit
//! tests and serve the window fitting of the crate. The shader's `axis_coverage`,
//! `occluded_fraction` and `penumbra_slopes` (and `CONTACT_EPSILON`) are kept equal to these by a
//! GPU test that cuts them out of the shader and compares (`crates/bench/tests/gpu/ssm.rs`,
//! `the_scatter_shader_functions_equal_their_cpu_mirrors`): change both together.

use softshadow_core::{
    glam::{Vec2, Vec3},
    SlopeFrustum,
};

/// A rectangle in slope space: `s` in `[s0, s1]`, `t` in `[t0, t1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlopeRect {
    /// Smallest s.
    pub s0: f32,
    /// Largest s.
    pub s1: f32,
    /// Smallest t.
    pub t0: f32,
    /// Largest t.
    pub t1: f32,
}

/// Receivers closer than this fraction of their depth behind a micro-patch are not shadowed by it:
/// it keeps `z_R - z_O` (the denominator of the backprojection) away from 0 when an occluder
/// touches the receiver, where the shadow is a contact shadow of zero width anyway.
pub const CONTACT_EPSILON: f32 = 1e-4;

/// Length of `[lo, hi]` inside `[-half, half]`, normalised by the light's extent `2 half`
/// (section 3.4: the light becomes `[0, 1]` and the intersection is two saturated differences).
/// A light of zero extent on this axis is a point: covered (1) when `lo <= 0 < hi`, else 0.
pub fn axis_coverage(lo: f32, hi: f32, half: f32) -> f32 {
    if half <= 0.0 {
        return if lo <= 0.0 && 0.0 < hi { 1.0 } else { 0.0 };
    }
    let u0 = ((lo + half) / (2.0 * half)).clamp(0.0, 1.0);
    let u1 = ((hi + half) / (2.0 * half)).clamp(0.0, 1.0);
    (u1 - u0).max(0.0)
}

/// Fraction of the light `half = (a, b)` hidden by the micro-patch `patch` (slopes) at depth
/// `z_o`, seen from the receiver point with slopes `receiver` at depth `z_r` (section 3.4).
///
/// Backprojection: the patch point with slope `s` maps through the receiver point onto the light
/// plane at `x = z_r z_o (s - sigma) / (z_r - z_o)`, so the occluded part of the light is the
/// axis-aligned rectangle `k (patch - sigma)` with `k = z_r z_o / (z_r - z_o)`, and the fraction
/// is the product of two interval overlaps. 0 when the patch is not in front of the receiver.
pub fn occluded_fraction(patch: SlopeRect, z_o: f32, receiver: Vec2, z_r: f32, half: Vec2) -> f32 {
    if !(z_o > 0.0 && z_o < z_r * (1.0 - CONTACT_EPSILON)) {
        return 0.0;
    }
    let k = z_r * z_o / (z_r - z_o);
    let x = axis_coverage(
        k * (patch.s0 - receiver.x),
        k * (patch.s1 - receiver.x),
        half.x,
    );
    let y = axis_coverage(
        k * (patch.t0 - receiver.y),
        k * (patch.t1 - receiver.y),
        half.y,
    );
    x * y
}

/// Apex of the penumbra pyramid of a micro-patch (section 3.3, Fig. 6): with `r = LL' / PP'` the
/// ratio of the light's width to the patch's width, `C_L O = r / (1 + r) C_L C_P`. The patch is
/// centred at `center` (light space) with half width `patch_half` along x; the light has half
/// width `a`. `None` for a point light (the apex is the light itself).
pub fn penumbra_apex(center: Vec3, patch_half: f32, a: f32) -> Option<Vec3> {
    if a <= 0.0 || patch_half <= 0.0 {
        return None;
    }
    let r = a / patch_half;
    Some(center * (r / (1.0 + r)))
}

/// Penumbra interval of a micro-patch along x on the plane `z_r` (section 3.3, Fig. 8) from its
/// apex: centre `C_R = (z_r / z_apex) O` (the line from the light centre through the apex) and
/// width `RR' = LL' (z_r - z_apex) / z_apex`. Returns `(lo, hi)` in light-space x.
pub fn penumbra_from_apex(apex: Vec3, a: f32, z_r: f32) -> (f32, f32) {
    let center = apex.x * z_r / apex.z;
    let half = a * (z_r - apex.z) / apex.z;
    (center - half, center + half)
}

/// The same penumbra extent in slope space, in the form the vertex shader uses because it stays
/// finite for a point light: the patch's slopes grown by `a (1 / z_o - 1 / z_r)` (and
/// `b (...)` along t). Receivers nearer than `z_r` have a smaller penumbra, so growing with the
/// farthest receiver depth bounds every receiver's penumbra.
pub fn penumbra_slopes(patch: SlopeRect, z_o: f32, z_r: f32, half: Vec2) -> SlopeRect {
    let grow = half * (1.0 / z_o - 1.0 / z_r).max(0.0);
    SlopeRect {
        s0: patch.s0 - grow.x,
        s1: patch.s1 + grow.x,
        t0: patch.t0 - grow.y,
        t1: patch.t1 + grow.y,
    }
}

/// Aspect ratio `a / b` the occluder map takes (section 3.2: axis-aligned with the light and with
/// its aspect ratio), 1 for a point or line light, clamped so that a very thin light still gets a
/// usable map.
pub fn light_aspect(half: Vec2) -> f32 {
    if half.x > 0.0 && half.y > 0.0 {
        (half.x / half.y).clamp(1.0 / 16.0, 16.0)
    } else {
        1.0
    }
}

/// The occluder-map window from the light centre: the tightest window over the casters'
/// light-space bounding-box corners whose slope extents have the ratio `aspect` (so every texel,
/// hence every micro-patch, has the light's aspect ratio). When casters cross the light plane
/// their slopes are unbounded: the window then also covers the receivers and the near plane drops
/// close to the light ([`SlopeFrustum::fit_casters`]). `None` when no caster is in front of the
/// light.
pub fn occluder_frustum(
    caster_corners: &[Vec3],
    casters_cross_light_plane: bool,
    receiver_corners: &[Vec3],
    aspect: f32,
) -> Option<SlopeFrustum> {
    // Fit a square window in a space where s is divided by the aspect, then stretch it back.
    let squeeze = |points: &[Vec3]| -> Vec<Vec3> {
        points
            .iter()
            .map(|p| Vec3::new(p.x / aspect, p.y, p.z))
            .collect()
    };
    let mut f = SlopeFrustum::fit_casters(
        Vec2::ZERO,
        &squeeze(caster_corners),
        casters_cross_light_plane,
        &squeeze(receiver_corners),
    )?;
    f.s_min *= aspect;
    f.s_max *= aspect;
    Some(f)
}

/// The soft-shadow-map (and receiver-map) window: the occluder window grown by the largest
/// penumbra, `a (1 / near - 1 / z_far)` along s and `b (...)` along t (section 3.3), clipped to
/// the receivers' window when they have one (a penumbra that falls beside every receiver is not
/// stored). Depth range: the casters' near plane to the receivers' farthest depth `z_far`.
pub fn ssm_frustum(
    occluder: &SlopeFrustum,
    receiver_corners: &[Vec3],
    half: Vec2,
) -> (SlopeFrustum, f32) {
    let z_far = receiver_corners
        .iter()
        .map(|p| p.z)
        .fold(occluder.far, f32::max);
    let grow = half * (1.0 / occluder.near - 1.0 / z_far).max(0.0);
    let mut f = SlopeFrustum {
        s_min: occluder.s_min - grow.x,
        s_max: occluder.s_max + grow.x,
        t_min: occluder.t_min - grow.y,
        t_max: occluder.t_max + grow.y,
        far: z_far * 1.02,
        ..*occluder
    };
    if let Some(r) = SlopeFrustum::fit(Vec2::ZERO, receiver_corners) {
        let clipped = SlopeFrustum {
            s_min: f.s_min.max(r.s_min),
            s_max: f.s_max.min(r.s_max),
            t_min: f.t_min.max(r.t_min),
            t_max: f.t_max.min(r.t_max),
            ..f
        };
        if clipped.s_min < clipped.s_max && clipped.t_min < clipped.t_max {
            f = clipped;
        }
    }
    (f, z_far)
}

/// Appendix A, equation (4): FP16 blending keeps every micro-patch's contribution when
/// `1 / z_o < 1 / z_r + 64 tan(alpha) / (N L)`, with `N` the occluder-map resolution, `L` the
/// light's width and `alpha` the half angle of the occluder map. `false` means FP16 accumulation
/// is expected to lose micro-patches.
pub fn fp16_blending_is_safe(
    z_o: f32,
    z_r: f32,
    tan_half_angle: f32,
    n: u32,
    light_width: f32,
) -> bool {
    1.0 / z_o < 1.0 / z_r + 64.0 * tan_half_angle / (n as f32 * light_width)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interval_intersection_saturates_to_the_light() {
        assert_eq!(axis_coverage(-1.0, 1.0, 0.5), 1.0);
        assert_eq!(axis_coverage(0.0, 0.25, 0.5), 0.25);
        assert!((axis_coverage(0.4, 2.0, 0.5) - 0.1).abs() < 1e-6);
        assert_eq!(axis_coverage(0.6, 2.0, 0.5), 0.0);
        assert_eq!(axis_coverage(-2.0, -0.6, 0.5), 0.0);
        // A point light is covered exactly when the interval contains 0 (half-open, so
        // neighbouring patches never both cover it).
        assert_eq!(axis_coverage(-0.1, 0.1, 0.0), 1.0);
        assert_eq!(axis_coverage(0.0, 0.1, 0.0), 1.0);
        assert_eq!(axis_coverage(-0.1, 0.0, 0.0), 0.0);
    }

    #[test]
    fn a_large_patch_hides_the_whole_light_and_a_far_one_none() {
        let half = Vec2::splat(0.5);
        let big = SlopeRect {
            s0: -1.0,
            s1: 1.0,
            t0: -1.0,
            t1: 1.0,
        };
        assert_eq!(occluded_fraction(big, 1.0, Vec2::ZERO, 2.0, half), 1.0);
        let far = SlopeRect {
            s0: 5.0,
            s1: 6.0,
            t0: 5.0,
            t1: 6.0,
        };
        assert_eq!(occluded_fraction(far, 1.0, Vec2::ZERO, 2.0, half), 0.0);
        // Behind or at the receiver: no occlusion, and no division by zero.
        assert_eq!(occluded_fraction(big, 2.0, Vec2::ZERO, 2.0, half), 0.0);
        assert_eq!(occluded_fraction(big, 3.0, Vec2::ZERO, 2.0, half), 0.0);
        // Touching the receiver from in front: finite and in [0, 1].
        let f = occluded_fraction(
            big,
            2.0 * (1.0 - 2.0 * CONTACT_EPSILON),
            Vec2::ZERO,
            2.0,
            half,
        );
        assert!((0.0..=1.0).contains(&f), "{f}");
    }

    /// Section 3.3: the apex construction and the slope-space growth give the same rectangle.
    #[test]
    fn penumbra_from_the_apex_equals_the_grown_patch() {
        for (cx, z_o, p, a, z_r) in [
            (0.3, 1.0, 0.01, 0.5, 2.0),
            (-1.2, 0.4, 0.05, 1.0, 4.0),
            (2.0, 3.5, 0.002, 0.1, 4.0),
        ] {
            let apex = penumbra_apex(Vec3::new(cx, 0.0, z_o), p, a).unwrap();
            let (lo, hi) = penumbra_from_apex(apex, a, z_r);
            let patch = SlopeRect {
                s0: (cx - p) / z_o,
                s1: (cx + p) / z_o,
                t0: 0.0,
                t1: 0.0,
            };
            let grown = penumbra_slopes(patch, z_o, z_r, Vec2::new(a, a));
            assert!((lo / z_r - grown.s0).abs() < 1e-5, "{lo} {grown:?}");
            assert!((hi / z_r - grown.s1).abs() < 1e-5, "{hi} {grown:?}");
        }
        assert_eq!(penumbra_apex(Vec3::ONE, 0.1, 0.0), None);
    }

    /// Outside the grown rectangle a patch hides nothing; just inside, it hides something.
    #[test]
    fn the_penumbra_rectangle_bounds_the_occlusion() {
        let half = Vec2::new(0.5, 0.3);
        let patch = SlopeRect {
            s0: 0.1,
            s1: 0.11,
            t0: -0.2,
            t1: -0.19,
        };
        let (z_o, z_r) = (1.3, 2.0);
        let pen = penumbra_slopes(patch, z_o, z_r, half);
        let t_mid = (patch.t0 + patch.t1) / 2.0;
        let at = |s: f32| occluded_fraction(patch, z_o, Vec2::new(s, t_mid), z_r, half);
        assert_eq!(at(pen.s0 - 1e-3), 0.0);
        assert_eq!(at(pen.s1 + 1e-3), 0.0);
        assert!(at(pen.s0 + 1e-3) > 0.0);
        assert!(at(pen.s1 - 1e-3) > 0.0);
    }

    /// For a planar square parallel to the light, the micro-patches tile it exactly and their
    /// backprojections tile the occluder's backprojection, so the sum over patches is the exact
    /// visibility (section 4.1: only the discretisation of the outline remains, here none).
    #[test]
    fn micro_patches_of_a_parallel_square_sum_to_the_exact_occlusion() {
        let half = Vec2::new(0.5, 0.5);
        let (z_o, z_r) = (1.0, 2.0);
        let n = 64;
        let side = 1.0 / n as f32;
        for receiver in [
            Vec2::ZERO,
            Vec2::new(0.6, 0.0),
            Vec2::new(0.45, -0.55),
            Vec2::new(0.9, 0.9),
        ] {
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n {
                    let patch = SlopeRect {
                        s0: -0.5 + i as f32 * side,
                        s1: -0.5 + (i + 1) as f32 * side,
                        t0: -0.5 + j as f32 * side,
                        t1: -0.5 + (j + 1) as f32 * side,
                    };
                    sum += occluded_fraction(patch, z_o, receiver, z_r, half);
                }
            }
            let whole = SlopeRect {
                s0: -0.5,
                s1: 0.5,
                t0: -0.5,
                t1: 0.5,
            };
            let exact = occluded_fraction(whole, z_o, receiver, z_r, half);
            assert!((sum - exact).abs() < 1e-4, "{receiver}: {sum} vs {exact}");
        }
    }

    #[test]
    fn the_occluder_window_has_the_light_aspect_and_covers_the_casters() {
        let corners = [
            Vec3::new(-0.5, -0.5, 1.0),
            Vec3::new(0.5, 0.5, 1.0),
            Vec3::new(-0.5, 0.5, 1.2),
            Vec3::new(0.5, -0.5, 1.2),
        ];
        let f = occluder_frustum(&corners, false, &[], 2.0).unwrap();
        let ratio = (f.s_max - f.s_min) / (f.t_max - f.t_min);
        assert!((ratio - 2.0).abs() < 1e-4, "{ratio}");
        for c in corners {
            assert!(f.s_min <= c.x / c.z && c.x / c.z <= f.s_max);
            assert!(f.t_min <= c.y / c.z && c.y / c.z <= f.t_max);
        }
        assert_eq!(
            occluder_frustum(&[Vec3::new(0.0, 0.0, -1.0)], false, &[], 1.0),
            None
        );
    }

    #[test]
    fn the_ssm_window_holds_every_penumbra_and_stays_inside_the_receivers() {
        let casters = [Vec3::new(-0.5, -0.5, 1.0), Vec3::new(0.5, 0.5, 1.0)];
        let occluder = occluder_frustum(&casters, false, &[], 1.0).unwrap();
        let half = Vec2::splat(0.5);
        let receivers = [Vec3::new(-4.0, -4.0, 2.0), Vec3::new(4.0, 4.0, 2.0)];
        let (ssm, z_far) = ssm_frustum(&occluder, &receivers, half);
        assert_eq!(z_far, 2.0);
        let corner = SlopeRect {
            s0: occluder.s_max - 0.01,
            s1: occluder.s_max,
            t0: occluder.t_max - 0.01,
            t1: occluder.t_max,
        };
        let pen = penumbra_slopes(corner, occluder.near, z_far, half);
        assert!(pen.s1 <= ssm.s_max + 1e-6 && pen.t1 <= ssm.t_max + 1e-6);
        // A small receiver clips the window.
        let small = [Vec3::new(-0.2, -0.2, 2.0), Vec3::new(0.2, 0.2, 2.0)];
        let (clipped, _) = ssm_frustum(&occluder, &small, half);
        assert!(clipped.s_max < 0.2 && clipped.s_min > -0.2);
    }

    /// Appendix A: a finer occluder map makes FP16 blending fail sooner (Fig. 14).
    #[test]
    fn fp16_blending_fails_sooner_at_higher_resolution() {
        let tan = 0.5;
        assert!(fp16_blending_is_safe(1.0, 2.0, tan, 32, 1.0));
        assert!(!fp16_blending_is_safe(1.0, 2.0, tan, 512, 1.0));
        assert!(!fp16_blending_is_safe(1.0, 2.0, tan, 128, 1.0));
    }
}
