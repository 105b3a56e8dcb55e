//! `msm` (moment soft shadows and its EVSM variants): within a bound of PCSS with the same box
//! kernel where no casters overlap in depth, its light leak on `stiff-light-leak` (too bright in
//! the umbra, clearly more than PCSS) and not on a single caster, and the light-bleeding
//! reduction trading that leak for darkness. Measured values (64², lavapipe) are in the comments
//! and in docs/TECHNIQUES.md ("msm").

use crate::common::{exact_bench, exact_errors};
use anyhow::{ensure, Result};

const SIZE: u32 = 64;

/// On atty-square (one square parallel to the light: no overlapping depths) the 4-moment map and
/// EVSM4 stay within 0.01 of PCSS with the grid (box) kernel, which their box filter imitates,
/// and far from `hard`; neither leaks in the umbra. EVSM2 does not converge there.
#[test]
fn msm_is_within_a_bound_of_pcss_on_a_single_caster() -> Result<()> {
    let mut bench = exact_bench()?;
    let pcss = exact_errors(
        &mut bench,
        "atty-square",
        "pcss",
        &[&["kernel=grid", "filter_samples=64", "shadow_map_size=512"]],
        SIZE,
    )?[0]
        .mae_shadowed;
    let hard = exact_errors(&mut bench, "atty-square", "hard", &[&[]], SIZE)?[0].mae_shadowed;
    let variants = ["msm4", "evsm4", "evsm2"];
    let reports = exact_errors(
        &mut bench,
        "atty-square",
        "msm",
        &[&["variant=msm4"], &["variant=evsm4"], &["variant=evsm2"]],
        SIZE,
    )?;
    // Measured: pcss grid 0.0355, hard 0.2063; msm4 0.0314, evsm4 0.0310 (both leak 0);
    // evsm2 0.2207.
    for (variant, report) in variants.iter().zip(&reports).take(2) {
        let e = report.mae_shadowed;
        ensure!(
            e <= pcss + 0.01,
            "{variant}: mae_shadowed {e:.4}, pcss grid {pcss:.4}: more than 0.01 worse"
        );
        ensure!(
            e < hard / 4.0,
            "{variant}: {e:.4} not far from hard {hard:.4}"
        );
        ensure!(
            report.brighter_umbra < 0.02,
            "{variant} leaks on a single caster: brighter_umbra {:.4}",
            report.brighter_umbra
        );
    }
    // EVSM2's positive warp alone lights the outer penumbra (docs/TECHNIQUES.md, msm): clearly
    // worse than EVSM4 with the same blocker search.
    let (evsm2, evsm4) = (reports[2].mae_shadowed, reports[1].mae_shadowed);
    ensure!(
        evsm2 > 2.0 * evsm4,
        "evsm2 {evsm2:.4} against evsm4 {evsm4:.4}: the positive warp alone no longer fails?"
    );
    Ok(())
}

/// `stiff-light-leak`: every filterable variant is too bright in the wide square's umbra, where
/// the blocker search and filter mix three depths; PCSS, which tests every sample's depth, is
/// not (more than 5x less, and 0.2 less). The light-bleeding reduction lowers the leak.
#[test]
fn msm_and_evsm_leak_light_where_casters_overlap_in_depth() -> Result<()> {
    let mut bench = exact_bench()?;
    let pcss = &exact_errors(&mut bench, "stiff-light-leak", "pcss", &[&[]], SIZE)?[0];
    ensure!(pcss.umbra_pixels > 100, "too few umbra pixels: {pcss:?}");
    let pcss_leak = pcss.brighter_umbra;
    let variants = [
        "msm4",
        "evsm2",
        "evsm4",
        "msm4, light_bleeding_reduction 0.5",
    ];
    let reports = exact_errors(
        &mut bench,
        "stiff-light-leak",
        "msm",
        &[
            &["variant=msm4"],
            &["variant=evsm2"],
            &["variant=evsm4"],
            &["variant=msm4", "light_bleeding_reduction=0.5"],
        ],
        SIZE,
    )?;
    let leaks: Vec<f64> = reports.iter().map(|r| r.brighter_umbra).collect();
    eprintln!("stiff-light-leak brighter_umbra: pcss {pcss_leak:.4}, {variants:?} {leaks:.4?}");
    // Measured: pcss 0.0305; msm4 0.8701, evsm2 1.0000, evsm4 0.8696; msm4 with reduction 0.5
    // 0.7532.
    for (variant, leak) in variants.iter().zip(&leaks).take(3) {
        ensure!(
            *leak > 5.0 * pcss_leak && *leak > pcss_leak + 0.2,
            "{variant}: brighter_umbra {leak:.4} not clearly above pcss's {pcss_leak:.4}"
        );
    }
    ensure!(
        leaks[3] < 0.9 * leaks[0],
        "light-bleeding reduction 0.5 did not lower msm4's leak: {:.4} against {:.4}",
        leaks[3],
        leaks[0]
    );
    Ok(())
}

/// The moment map and its mip chain are light-space work: kept while only the camera moves, and
/// their passes are named.
#[test]
fn msm_keeps_its_moment_map_while_only_the_camera_moves() -> Result<()> {
    use softshadow_core::{Renderer, SceneGpu};
    let gpu = crate::common::gpu()?;
    let scene = softshadow_scenes::load("atty-square")?.scene;
    let scene_gpu = SceneGpu::upload(&gpu, &scene);
    let mut renderer = Renderer::new(&gpu, SIZE, SIZE)?;
    let mut technique = softshadow::registry().find("msm")?.create_with(&gpu, &[])?;
    let first = renderer.render(
        &scene_gpu,
        &scene.camera,
        &scene.light,
        technique.as_mut(),
        None,
    )?;
    for pass in ["msm/shadow_map", "msm/moments", "msm/mips", "msm/filter"] {
        ensure!(
            first.passes_run.iter().any(|p| p == pass),
            "first frame lacks {pass}: {:?}",
            first.passes_run
        );
    }
    let mut camera = scene.camera;
    camera.eye += softshadow_core::glam::Vec3::new(0.2, 0.0, 0.0);
    let moved = renderer.render(&scene_gpu, &camera, &scene.light, technique.as_mut(), None)?;
    let technique_passes: Vec<&String> = moved
        .passes_run
        .iter()
        .filter(|p| p.starts_with("msm/"))
        .collect();
    ensure!(
        technique_passes == ["msm/filter"],
        "camera-only frame ran {:?}",
        moved.passes_run
    );
    Ok(())
}
