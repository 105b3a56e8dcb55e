//! `gltf_export::write_glb` writes what `load` reads back: the same triangles in the same places.

use glam::Vec3;
use softshadow_core::Scene;
use softshadow_scenes::{builtin, gltf_export::write_glb, load};

/// Every instance's world-space triangle corners, in order.
fn world_corners(scene: &Scene) -> Vec<Vec3> {
    scene
        .instances
        .iter()
        .flat_map(|i| {
            let mesh = &scene.meshes[i.mesh];
            mesh.indices
                .iter()
                .map(move |&k| i.transform.transform_point3(mesh.positions[k as usize]))
        })
        .collect()
}

#[test]
fn exported_scenes_load_back_with_the_same_triangles() {
    let dir = tempfile::tempdir().unwrap();
    for id in ["polycount-1k", "atty-square", "foliage", "fence", "atrium"] {
        let scene = builtin(id, &[]).unwrap();
        let path = dir.path().join(format!("{id}.glb"));
        write_glb(&scene, &path).unwrap();
        let back = load(path.to_str().unwrap()).unwrap().scene;
        // The loader wraps a model in a ground of 2 triangles, after the model's instances.
        assert_eq!(back.triangle_count(), scene.triangle_count() + 2, "{id}");
        let (a, b) = (world_corners(&scene), world_corners(&back));
        assert_eq!(b.len(), a.len() + 6, "{id}");
        let worst = a
            .iter()
            .zip(&b)
            .map(|(p, q)| p.distance(*q))
            .fold(0.0, f32::max);
        assert!(worst < 1e-4, "{id}: corners moved by up to {worst}");
    }
}

#[test]
fn an_unwritable_path_is_one_line_naming_it() {
    let scene = builtin("atty-square", &[]).unwrap();
    let path = std::path::Path::new("/nonexistent-folder/x.glb");
    let message = write_glb(&scene, path).unwrap_err().to_string();
    assert!(message.contains("/nonexistent-folder/x.glb"), "{message}");
    assert!(!message.contains('\n'), "{message}");
}

#[test]
fn a_glb_spec_loads_the_builtin_through_the_gltf_loader() {
    let direct = builtin("polycount-1k", &[]).unwrap();
    let loaded = load("glb:polycount-1k").unwrap().scene;
    assert_eq!(loaded.triangle_count(), direct.triangle_count() + 2);
    let message = load("glb:no-such-scene").unwrap_err().to_string();
    assert!(message.contains("no-such-scene"), "{message}");
}
