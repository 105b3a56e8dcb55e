//! Prints the builtin scenes, or loads each scene spec given on the command line and summarises
//! it (or prints the error).
//!
//! `cargo run -p softshadow-scenes --example scene_info -- atty-square:light_width=0.5 assets/scenes/primitives.toml`

fn main() {
    let specs: Vec<String> = std::env::args().skip(1).collect();
    if specs.is_empty() {
        for info in softshadow_scenes::builtin_scenes() {
            println!("{:<18} {}", info.id, info.description);
            for p in &info.params {
                println!(
                    "    {:<18} default {:<8} {} ({})",
                    p.name,
                    p.default,
                    p.description,
                    p.range_text()
                );
            }
        }
        return;
    }
    for spec in specs {
        match softshadow_scenes::load(&spec) {
            Ok(loaded) => {
                let s = &loaded.scene;
                println!(
                    "{spec}: `{}`, {} meshes, {} instances, {} triangles",
                    s.name,
                    s.meshes.len(),
                    s.instances.len(),
                    s.triangle_count()
                );
                for w in &loaded.warnings {
                    println!("  warning: {w}");
                }
            }
            Err(e) => println!("{spec}: error: {e}"),
        }
    }
}
