//! The stiff-case family (issue 6): every case loads and validates, says what it repaired, and
//! its parameter puts the geometry where its description says.

use glam::Vec3;
use softshadow_core::StiffClass;
use softshadow_scenes::{
    builtin_scenes, load,
    stiff::{self, PREFIX},
};

/// The cases when this test was written.
const EXPECTED: [&str; 19] = [
    "stiff-contact",
    "stiff-near-light",
    "stiff-point-light",
    "stiff-wide-light",
    "stiff-grazing",
    "stiff-depth-range",
    "stiff-zero-thickness",
    "stiff-partly-outside",
    "stiff-no-occluder",
    "stiff-aspect-100",
    "stiff-tiny-patches",
    "stiff-degenerate",
    "stiff-behind-light",
    "stiff-receiver-behind-light",
    "stiff-light-up",
    "stiff-fusion",
    "stiff-light-leak",
    "stiff-large-light",
    "stiff-thin-roof",
];

fn caster_depths(spec: &str) -> Vec<f32> {
    let scene = load(spec).unwrap().scene;
    let (_, _, z) = scene.light.basis();
    let mut depths = Vec::new();
    for instance in scene.instances.iter().filter(|i| i.casts_shadow) {
        let mesh = &scene.meshes[instance.mesh];
        for &i in &mesh.indices {
            let p = instance
                .transform
                .transform_point3(mesh.positions[i as usize]);
            depths.push((p - scene.light.center).dot(z));
        }
    }
    depths
}

#[test]
fn every_stiff_case_loads_and_only_the_broken_ones_warn() {
    let cases = stiff::cases();
    let ids: Vec<&str> = cases.iter().map(|case| case.info.id).collect();
    let listed: Vec<&str> = builtin_scenes()
        .iter()
        .map(|b| b.id)
        .filter(|id| id.starts_with(PREFIX))
        .collect();
    assert_eq!(listed, ids);
    // A new case needs no line here (its class gives it every technique's bound); none of these
    // may go missing, and no id comes twice.
    for id in EXPECTED {
        assert!(ids.contains(&id), "{id} is no longer a stiff case");
    }
    for (k, id) in ids.iter().enumerate() {
        assert!(!ids[..k].contains(id), "{id} twice");
    }
    for case in &cases {
        let id = case.info.id;
        let loaded = load(id).unwrap_or_else(|e| panic!("{id}: {e}"));
        let scene = &loaded.scene;
        assert!(scene.instances.iter().any(|i| i.receives_shadow), "{id}");
        assert_eq!(
            scene.instances.iter().any(|i| i.casts_shadow),
            case.class != StiffClass::Unshadowed,
            "{id}"
        );
        for mesh in &scene.meshes {
            assert!(mesh.positions.iter().all(|p| p.is_finite()), "{id}");
        }
        match id {
            "stiff-degenerate" => {
                assert_eq!(
                loaded.warnings,
                ["mesh `occluder with bad triangles` from builtin scene `stiff-degenerate`: \
                  dropped 2 degenerate, 2 non-finite and 1 out-of-range triangles"]
            )
            }
            // The zero-height box's eight side triangles have no area.
            "stiff-zero-thickness" => assert_eq!(
                loaded.warnings,
                [
                    "mesh `box of zero height` from builtin scene `stiff-zero-thickness`: \
                  dropped 8 degenerate triangles"
                ]
            ),
            _ => assert!(loaded.warnings.is_empty(), "{id}: {:?}", loaded.warnings),
        }
    }
}

#[test]
fn parameters_put_the_geometry_where_the_description_says() {
    // Occluder 1e-3 x 2 below the light.
    let near = caster_depths("stiff-near-light");
    assert!(near.iter().all(|d| (d - 2e-3).abs() < 1e-5), "{near:?}");
    let near = caster_depths("stiff-near-light:light_gap=0.25");
    assert!(near.iter().all(|d| (d - 0.5).abs() < 1e-5), "{near:?}");
    // Caster depth range near/far about 1e-4.
    let range = caster_depths("stiff-depth-range");
    let (lo, hi) = range
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), d| (a.min(*d), b.max(*d)));
    assert!((lo - 1e-3).abs() < 1e-5 && lo / hi < 1.1e-4, "{lo} {hi}");
    // The wall crosses the light plane.
    let wall = caster_depths("stiff-partly-outside");
    assert!(wall.iter().any(|d| *d < 0.0) && wall.iter().any(|d| *d > 0.0));
    // Touching: the lowest caster point is on the ground.
    let contact = load("stiff-contact").unwrap().scene;
    let lowest = contact
        .instances
        .iter()
        .filter(|i| i.casts_shadow)
        .flat_map(|i| {
            contact.meshes[i.mesh]
                .positions
                .iter()
                .map(|p| i.transform.transform_point3(*p).y)
        })
        .fold(f32::MAX, f32::min);
    assert!(lowest.abs() < 1e-6, "{lowest}");

    let light = |spec: &str| load(spec).unwrap().scene.light;
    assert_eq!(light("stiff-point-light").width, 1e-4);
    let wide = light("stiff-wide-light");
    assert!((wide.width - 3.0).abs() < 1e-5);
    let aspect = light("stiff-aspect-100");
    assert!((aspect.width / aspect.height - 100.0).abs() < 1e-3);
    // 85 degrees between the ground normal and the direction to the light.
    let grazing = light("stiff-grazing");
    let to_light = -grazing.direction.normalize();
    let angle = to_light.dot(Vec3::Y).acos().to_degrees();
    assert!((angle - 85.0).abs() < 1e-3, "{angle}");
}

#[test]
fn out_of_range_parameters_say_what_to_use() {
    for (spec, hint) in [
        ("stiff-near-light:light_gap=0", "use a value > 0 and <= 0.5"),
        ("stiff-grazing:angle_degrees=90", "use 0 to 89"),
        ("stiff-aspect-100:aspect=0.5", "use 1 to 1000"),
    ] {
        let e = load(spec).unwrap_err().to_string();
        assert!(e.contains(hint), "{spec}: {e}");
    }
}

#[test]
fn each_case_declares_its_light_kind_and_the_new_kinds_put_light_and_casters_as_described() {
    use softshadow_core::LightKind;
    let kind_of = |id: &str| {
        let cases = stiff::cases();
        let case = cases.iter().find(|c| c.info.id == id).unwrap();
        assert_eq!(
            case.light_kind(),
            load(id).unwrap().scene.light.kind,
            "{id}"
        );
        case.light_kind()
    };
    for (id, kind) in [
        ("stiff-contact", LightKind::Rect),
        ("stiff-masked-checker", LightKind::Rect),
        ("stiff-disk-tiny", LightKind::Disk),
        ("stiff-disk-huge", LightKind::Disk),
        ("stiff-sphere-near", LightKind::Sphere),
        ("stiff-sun-grazing", LightKind::Sun),
        ("stiff-spot-narrow", LightKind::Spot),
        ("stiff-sphere-in-ground", LightKind::Sphere),
    ] {
        assert_eq!(kind_of(id), kind, "{id}");
    }
    let light = |spec: &str| load(spec).unwrap().scene.light;
    // The sun 3 degrees above the horizon: a 0.3 post's shadow about 5.7 long.
    let sun = light("stiff-sun-grazing");
    let elevation = (-sun.direction.normalize().y).asin().to_degrees();
    assert!((elevation - 3.0).abs() < 1e-3, "{elevation}");
    assert!((0.3 / elevation.to_radians().tan() - 5.72).abs() < 0.01);
    // The sphere's centre below its radius: part of it lies under the ground.
    let sunk = light("stiff-sphere-in-ground");
    assert!(sunk.center.y < sunk.radius && sunk.center.y > 0.0);
    // The squares just under the sphere's lowest point.
    let near = caster_depths("stiff-sphere-near");
    let closest = near.iter().copied().fold(f32::MAX, f32::min);
    assert!((closest - 0.6).abs() < 1e-5, "{closest}");
    let spot = light("stiff-spot-narrow:cone_outer_degrees=20");
    assert_eq!(
        (spot.cone_inner_degrees, spot.cone_outer_degrees),
        (12.0, 20.0)
    );
}

#[test]
fn the_alpha_tested_cases_have_masked_casters_edge_on_cards_and_single_texel_holes() {
    for id in [
        "stiff-masked-checker",
        "stiff-leaves-edge-on",
        "stiff-texel-holes",
    ] {
        let scene = load(id).unwrap().scene;
        assert!(scene.has_masked_casters(), "{id}");
        assert!(
            scene
                .instances
                .iter()
                .all(|i| !(i.casts_shadow && i.receives_shadow)),
            "{id}: casters only"
        );
    }
    // Every card contains the light's direction: its normals are perpendicular to it.
    let leaves = load("stiff-leaves-edge-on").unwrap().scene;
    let cards = leaves
        .instances
        .iter()
        .find(|i| i.material.is_some())
        .unwrap();
    for n in &leaves.meshes[cards.mesh].normals {
        assert!(n.dot(leaves.light.direction).abs() < 1e-5, "{n}");
    }
    // One texel in nine is a hole, and only under the cut-off: alpha 0.45, not 0.
    let holes = load("stiff-texel-holes").unwrap().scene;
    let texture = &holes.textures[0];
    let alphas: Vec<u8> = texture.rgba8.chunks_exact(4).map(|t| t[3]).collect();
    let cut = alphas.iter().filter(|a| **a < 128).count();
    assert_eq!(cut, 16 * 16, "{cut} holes in 48 x 48");
    assert!(
        alphas.iter().all(|a| *a == 255 || *a == 115),
        "alphas 1 and 0.45 only"
    );
}
