//! Builtin scenes: every id builds and validates, has receivers and casters, lies in its
//! triangle band, is finite and in front of its light; parameters parse and errors are clear.

use std::time::Instant;

use glam::Vec3;
use softshadow_core::Scene;
use softshadow_scenes::{builtin, builtin_scenes, load, AttySquare, SceneError};

const IDS: [&str; 16] = [
    "atty-square",
    "blob-floating",
    "blob-contact",
    "balls-3x3x3",
    "single-silhouette",
    "pdsm-cylinder",
    "pdsm-quads",
    "polycount-1k",
    "polycount-10k",
    "polycount-100k",
    "polycount-1m",
    "polycount-5m",
    "foliage",
    "fence",
    "atrium",
    "outdoor",
];

/// Allowed total triangle count (instances included) per id.
fn band(id: &str) -> (usize, usize) {
    let around = |n: f64| ((n * 0.85) as usize, (n * 1.15) as usize);
    match id {
        "atty-square" => (6, 6),
        "blob-floating" | "blob-contact" => (80_000, 120_000),
        "balls-3x3x3" => (27 * 100, 27 * 2_000),
        "single-silhouette" | "pdsm-quads" => (14, 14),
        "pdsm-cylinder" => (50, 1_000),
        "polycount-1k" => around(1e3),
        "polycount-10k" => around(1e4),
        "polycount-100k" => around(1e5),
        "polycount-1m" => around(1e6),
        "polycount-5m" => around(5e6),
        "foliage" => (8_000, 9_000),
        "fence" => (100, 120),
        "atrium" => (1_500, 3_000),
        "outdoor" => (34_000, 38_000),
        other => panic!("no band for {other}"),
    }
}

fn world_vertices(scene: &Scene, filter: impl Fn(&softshadow_core::Instance) -> bool) -> Vec<Vec3> {
    scene
        .instances
        .iter()
        .filter(|i| filter(i))
        .flat_map(|i| {
            let mesh = &scene.meshes[i.mesh];
            mesh.indices
                .iter()
                .map(move |&k| i.transform.transform_point3(mesh.positions[k as usize]))
        })
        .collect()
}

fn check_scene(id: &str, scene: &Scene) {
    scene.validate().unwrap();
    assert_eq!(scene.name, id);
    assert!(
        scene.instances.iter().any(|i| i.receives_shadow),
        "{id}: no receiver"
    );
    assert!(
        scene.instances.iter().any(|i| i.casts_shadow),
        "{id}: no caster"
    );
    let (lo, hi) = band(id);
    let count = scene.triangle_count();
    assert!(
        (lo..=hi).contains(&count),
        "{id}: {count} triangles, want {lo}..={hi}"
    );
    for mesh in &scene.meshes {
        assert!(
            mesh.positions.iter().all(|p| p.is_finite()),
            "{id}: non-finite position"
        );
        assert_eq!(mesh.normals.len(), mesh.positions.len(), "{id}: normals");
    }
    // Ground planes are receivers only.
    for instance in &scene.instances {
        if scene.meshes[instance.mesh].name == "ground" {
            assert!(
                !instance.casts_shadow && instance.receives_shadow,
                "{id}: ground flags"
            );
        }
    }
    // Everything the light has to see is in front of its plane.
    let light = scene.light;
    let direction = light.direction.normalize();
    for p in world_vertices(scene, |i| i.casts_shadow) {
        let depth = (p - light.center).dot(direction);
        assert!(
            depth > 0.0,
            "{id}: caster vertex {p} behind the light (depth {depth})"
        );
    }
    for p in world_vertices(scene, |i| i.receives_shadow) {
        assert!(
            (p - light.center).dot(direction) > 0.0,
            "{id}: receiver behind the light"
        );
    }
    // The camera looks at the scene, not away from it.
    let view = (scene.camera.target - scene.camera.eye).normalize();
    let receivers = scene.bounds(|i| i.receives_shadow);
    let middle = (receivers.min + receivers.max) * 0.5;
    assert!(
        (middle - scene.camera.eye).dot(view) > 0.0,
        "{id}: camera looks away"
    );
}

#[test]
fn builtin_list_has_exactly_the_documented_ids() {
    let list = builtin_scenes();
    let ids: Vec<&str> = list.iter().map(|b| b.id).collect();
    // The paper scenes, then the stiff cases (tested in tests/stiff.rs).
    assert_eq!(ids[..IDS.len()], IDS);
    assert!(ids[IDS.len()..].iter().all(|id| id.starts_with("stiff-")));
    for info in &list {
        assert!(!info.description.is_empty() && !info.description.contains('\n'));
        for p in &info.params {
            p.check(info.id, p.default).unwrap();
            assert!(!p.description.is_empty());
        }
    }
}

#[test]
fn every_builtin_builds_and_passes_the_checks() {
    for id in IDS {
        let start = Instant::now();
        let loaded = load(id).unwrap_or_else(|e| panic!("{id}: {e}"));
        assert!(loaded.warnings.is_empty(), "{id}: {:?}", loaded.warnings);
        check_scene(id, &loaded.scene);
        let seconds = start.elapsed().as_secs_f64();
        assert!(seconds < 20.0, "{id} took {seconds:.1} s");
    }
}

#[test]
fn atty_square_is_exactly_the_paper_setup() {
    let scene = builtin("atty-square", &[]).unwrap();
    assert_eq!(scene.instances.len(), 2);
    let ground = &scene.instances[0];
    assert!(!ground.casts_shadow && ground.receives_shadow);
    let g = scene.bounds(|i| !i.casts_shadow);
    assert_eq!(
        (g.min, g.max),
        (Vec3::new(-4.0, 0.0, -4.0), Vec3::new(4.0, 0.0, 4.0))
    );

    let occluder = &scene.instances[1];
    assert!(occluder.casts_shadow && !occluder.receives_shadow);
    let mesh = &scene.meshes[occluder.mesh];
    assert_eq!(mesh.triangle_count(), 4);
    let o = scene.bounds(|i| i.casts_shadow);
    assert_eq!(
        (o.min, o.max),
        (Vec3::new(-0.5, 1.0, -0.5), Vec3::new(0.5, 1.0, 0.5))
    );
    // Two-sided: two triangles face up, two face down.
    let up = mesh
        .indices
        .chunks_exact(3)
        .filter(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[t[k] as usize]);
            (b - a).cross(c - a).y > 0.0
        })
        .count();
    assert_eq!(up, 2);

    let light = scene.light;
    assert_eq!(light.center, Vec3::new(0.0, 2.0, 0.0));
    assert_eq!((light.direction, light.up), (Vec3::NEG_Y, Vec3::Z));
    assert_eq!((light.width, light.height), (1.0, 1.0));
    let camera = scene.camera;
    assert_eq!(
        (camera.eye, camera.target, camera.up),
        (Vec3::new(0.0, 3.2, 4.0), Vec3::new(0.0, 0.0, 0.4), Vec3::Y)
    );
    assert_eq!(
        (camera.fov_y_degrees, camera.near, camera.far),
        (45.0, 0.05, 50.0)
    );

    // The struct API builds the same scene.
    let direct = AttySquare::default().scene().unwrap();
    assert_eq!(direct.content_hash(), scene.content_hash());
}

#[test]
fn parametrised_ids_parse() {
    let scene = load("atty-square:occluder_height=1.5,light_width=0.2")
        .unwrap()
        .scene;
    let o = scene.bounds(|i| i.casts_shadow);
    assert_eq!((o.min.y, o.max.y), (1.5, 1.5));
    assert_eq!((scene.light.width, scene.light.height), (0.2, 0.2));

    let scene = load(" atty-square : occluder_size = 2 , occluder_offset_x=-1, light_height=3, occluder_height=0 ")
        .unwrap()
        .scene;
    let o = scene.bounds(|i| i.casts_shadow);
    assert_eq!(
        (o.min, o.max),
        (Vec3::new(-2.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 1.0))
    );
    assert_eq!(scene.light.center.y, 3.0);

    let params = [("light_width".to_string(), 0.0)];
    assert_eq!(builtin("atty-square", &params).unwrap().light.width, 0.0);

    let scene = load("pdsm-cylinder:light_width=1.5").unwrap().scene;
    assert_eq!(scene.light.width, 1.5);
    assert!(scene.light.direction.x < 0.0 && scene.light.direction.y < 0.0);

    let scene = load("blob-floating:triangles=5000,light_width=0.5")
        .unwrap()
        .scene;
    let count = scene.triangle_count() - 2;
    assert!((4_500..5_500).contains(&count), "{count}");
    assert_eq!(scene.light.width, 0.5);
}

#[test]
fn blob_contact_touches_the_ground_and_floating_does_not() {
    let contact = load("blob-contact:triangles=20000").unwrap().scene;
    assert_eq!(contact.bounds(|i| i.casts_shadow).min.y, 0.0);
    let floating = load("blob-floating:triangles=20000").unwrap().scene;
    let b = floating.bounds(|i| i.casts_shadow);
    assert!(b.min.y > 0.4 && b.max.y < 2.0, "{b:?}");
    let center = (b.min + b.max) * 0.5;
    assert!((center.y - 1.2).abs() < 0.15, "{center}");
}

#[test]
fn paper_layouts() {
    let balls = builtin("balls-3x3x3", &[]).unwrap();
    assert_eq!(
        balls.instances.iter().filter(|i| i.casts_shadow).count(),
        27
    );
    let b = balls.bounds(|i| i.casts_shadow);
    assert!(
        b.min.abs_diff_eq(Vec3::new(-0.73, 0.67, -0.73), 1e-4),
        "{b:?}"
    );

    let box_scene = builtin("single-silhouette", &[]).unwrap();
    let b = box_scene.bounds(|i| i.casts_shadow);
    assert!(b.min.abs_diff_eq(Vec3::new(-0.5, 0.4, -0.5), 1e-6), "{b:?}");
    assert!(b.max.abs_diff_eq(Vec3::new(0.5, 1.4, 0.5), 1e-6), "{b:?}");
    assert_eq!(box_scene.light.width, 2.0);

    let cylinder = builtin("pdsm-cylinder", &[]).unwrap();
    let b = cylinder.bounds(|i| i.casts_shadow);
    assert!(
        (b.min.y, b.max.y) == (0.0, 1.4) && (b.max.x - 0.25).abs() < 1e-6,
        "{b:?}"
    );
    assert_eq!(cylinder.light.center, Vec3::new(2.5, 3.0, 0.0));
    let aim = (Vec3::new(0.0, 0.3, 0.0) - cylinder.light.center).normalize();
    assert!(cylinder.light.direction.abs_diff_eq(aim, 1e-6));
    assert_eq!(cylinder.light.width, 0.4);

    let quads = builtin("pdsm-quads", &[]).unwrap();
    let heights: Vec<(f32, f32)> = quads
        .instances
        .iter()
        .filter(|i| i.casts_shadow)
        .map(|i| (i.transform.w_axis.x, i.transform.w_axis.y))
        .collect();
    assert_eq!(heights, vec![(-1.2, 0.25), (0.0, 0.8), (1.2, 1.5)]);
}

fn message(spec: &str) -> String {
    let err = load(spec).expect_err(spec).to_string();
    assert!(!err.contains('\n'), "{err}");
    err
}

#[test]
fn bad_ids_and_parameters_say_what_to_do() {
    assert_eq!(
        message("foo"),
        "unknown scene `foo`: run `workbench list` to see scene ids, or give a path to a .toml/.gltf/.glb file"
    );
    assert!(message("foo:light_width=1").starts_with("unknown scene `foo`"));
    assert_eq!(
        message("atty-square:foo=1"),
        "unknown parameter `foo` for scene `atty-square`: known parameters are `light_width`, `light_height`, `occluder_height`, `occluder_size`, `occluder_offset_x`"
    );
    assert_eq!(
        message("atty-square:light_width=NaN"),
        "parameter `light_width` = NaN is not finite: give a finite number"
    );
    assert!(message("atty-square:light_width=inf").contains("is not finite"));
    assert_eq!(
        message("atty-square:light_width=5"),
        "parameter `light_width` = 5 for scene `atty-square` is out of range: use 0 to 4"
    );
    assert!(message("atty-square:occluder_size=0").contains("use a value > 0"));
    assert!(message("atty-square:occluder_offset_x=-3.5").contains("use -3 to 3"));
    let m = message("atty-square:occluder_height=2");
    assert!(
        m.contains("occluder_height") && m.contains("< light_height"),
        "{m}"
    );
    let m = message("atty-square:light_width=wide");
    assert!(m.contains("`wide`") && m.contains("not a number"), "{m}");
    let m = message("atty-square:light_width");
    assert!(m.contains("has no value") && m.contains("key=value"), "{m}");
    assert!(message("atty-square:light_width=1,light_width=2").contains("given twice"));
    assert!(message("blob-floating:triangles=10").contains("use 1000 to 2000000"));
    assert!(message("balls-3x3x3:triangles=1000").contains("known parameters are `light_width`"));

    let err = builtin("nope", &[]).unwrap_err();
    assert!(matches!(err, SceneError::UnknownScene { .. }));
    let err = AttySquare {
        light_height: f64::NAN,
        ..AttySquare::default()
    }
    .scene()
    .unwrap_err();
    assert!(
        matches!(err, SceneError::ParameterNotFinite { .. }),
        "{err:?}"
    );
}

#[test]
fn builtins_are_deterministic() {
    for id in [
        "blob-contact:triangles=3000",
        "polycount-10k",
        "balls-3x3x3",
    ] {
        let a = load(id).unwrap().scene.content_hash();
        let b = load(id).unwrap().scene.content_hash();
        assert_eq!(a, b, "{id}");
    }
}

#[test]
fn light_in_a_builtin_spec_makes_its_light_that_kind() {
    use softshadow_core::LightKind;
    let rect = softshadow_scenes::load("atty-square:light_width=0.8")
        .unwrap()
        .scene;
    let disk = softshadow_scenes::load("atty-square:light=disk,light_width=0.8")
        .unwrap()
        .scene;
    assert_eq!(disk.light.kind, LightKind::Disk);
    assert_eq!(disk.light.radius, 0.4);
    assert_eq!(disk.light.center, rect.light.center);
    assert_eq!(disk.instances.len(), rect.instances.len());
    let sun = softshadow_scenes::load("blob-floating:light=sun")
        .unwrap()
        .scene;
    assert_eq!(sun.light.kind, LightKind::Sun);
    let e = softshadow_scenes::load("atty-square:light=moon")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("light `moon` is not a light kind") && e.contains("rect | disk"),
        "{e}"
    );
}

/// Each scene like those engines light has a path of its own in `assets/paths/` (docs/SCENES.md,
/// "Builtin scenes"): it loads, passes the path checks against its scene, starts at the scene's
/// own view, moves what it says it moves, and ends with the 0.6 s hold a lag measurement needs.
#[test]
fn the_engine_scenes_paths_start_at_their_view_and_end_still() {
    use softshadow_scenes::path;
    let assets = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/paths/");
    for (id, file, moves_light) in [
        ("foliage", "foliage-sun.toml", true),
        ("fence", "fence-walk.toml", false),
        ("atrium", "atrium-afternoon.toml", true),
    ] {
        let mut scene = load(id).expect(id).scene;
        let spec = format!("{assets}{file}");
        let made = path::resolve(&spec, &mut scene, &[]).unwrap_or_else(|e| panic!("{file}: {e}"));
        let start = made.pose(&scene, 0.0);
        let end = made.pose(&scene, made.duration);
        let near = |a: Vec3, b: Vec3| (a - b).length() < 1e-4;
        assert!(
            near(start.camera.eye, scene.camera.eye),
            "{file}: starts elsewhere"
        );
        assert!(
            near(start.light.center, scene.light.center),
            "{file}: light starts elsewhere"
        );
        let light_moved = !near(end.light.center, scene.light.center);
        let camera_moved = !near(end.camera.eye, scene.camera.eye);
        assert_eq!(
            (light_moved, camera_moved),
            (moves_light, !moves_light),
            "{file}"
        );
        let hold = made.pose(&scene, made.duration - 0.6);
        assert!(
            near(hold.light.center, end.light.center) && near(hold.camera.eye, end.camera.eye),
            "{file}: must hold still for its last 0.6 s"
        );
    }
}
