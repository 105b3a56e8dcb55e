use softshadow_core::{
    glam::{Mat4, Vec3},
    AreaLight, Camera, Gpu, Instance, Mesh, Renderer, Scene, SceneGpu, ShadingMode,
};

fn quad(size: f32) -> Mesh {
    let h = size / 2.0;
    Mesh {
        name: "quad".into(),
        positions: vec![
            Vec3::new(-h, 0.0, -h),
            Vec3::new(h, 0.0, -h),
            Vec3::new(h, 0.0, h),
            Vec3::new(-h, 0.0, h),
        ],
        normals: vec![Vec3::Y; 4],
        indices: vec![0, 2, 1, 0, 3, 2],
    }
}

#[test]
fn smoke() -> anyhow::Result<()> {
    let gpu = Gpu::new_headless()?;
    eprintln!("{:?} {:?}", gpu.summary(), gpu.features());
    let mut ground = Instance::new(0, Mat4::IDENTITY);
    ground.casts_shadow = false;
    let mut occ = Instance::new(1, Mat4::from_translation(Vec3::Y));
    occ.receives_shadow = false;
    let scene = Scene {
        name: "t".into(),
        meshes: vec![quad(8.0), quad(1.0)],
        instances: vec![ground, occ],
        light: AreaLight {
            center: Vec3::new(0.0, 2.0, 0.0),
            direction: Vec3::NEG_Y,
            up: Vec3::Z,
            width: 1.0,
            height: 1.0,
            intensity: 1.0,
        },
        camera: Camera {
            eye: Vec3::new(0.0, 3.2, 4.0),
            target: Vec3::new(0.0, 0.0, 0.4),
            ..Camera::default()
        },
    };
    let sg = SceneGpu::upload(&gpu, &scene);
    let mut r = Renderer::new(&gpu, 64, 64)?;
    let mut t = (softshadow_hard::info().create)(&gpu)?;
    let out = r.render(
        &sg,
        &scene.camera,
        &scene.light,
        t.as_mut(),
        Some(ShadingMode::Shaded),
    )?;
    eprintln!("{out:?}");
    let v = r.read_visibility()?;
    let m = r.read_receiver_mask()?;
    let shadowed = v.iter().zip(&m).filter(|(v, m)| **m && **v < 0.5).count();
    eprintln!(
        "receivers {} shadowed {}",
        m.iter().filter(|x| **x).count(),
        shadowed
    );
    for y in (0..64).step_by(4) {
        let row: String = (0..64)
            .step_by(2)
            .map(|x| {
                if !m[y * 64 + x] {
                    ' '
                } else if v[y * 64 + x] < 0.5 {
                    '#'
                } else {
                    '.'
                }
            })
            .collect();
        eprintln!("{row}");
    }
    assert!(shadowed > 0);
    Ok(())
}
