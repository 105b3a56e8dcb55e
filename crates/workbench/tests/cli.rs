//! The `workbench` binary as a user runs it: `list`, `bench`, and bad input.

use std::process::{Command, Output};

use anyhow::{ensure, Context, Result};
use serde_json::Value;

fn workbench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(args)
        .output()
        .expect("the workbench binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| !l.contains("XDG_RUNTIME_DIR"))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn list_json_names_every_technique_and_scene() -> Result<()> {
    let o = workbench(&["list", "--json"]);
    ensure!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout)?;
    let ids = |key: &str| -> Vec<String> {
        v[key]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|x| x["id"].as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default()
    };
    // Every registered technique, in registry order, each with every declared parameter.
    let techniques = ids("techniques");
    let registered: Vec<String> = softshadow::registry()
        .iter()
        .map(|t| t.id.to_string())
        .collect();
    ensure!(
        techniques == registered,
        "list has {techniques:?}, the registry {registered:?}"
    );
    for (k, info) in softshadow::registry().iter().enumerate() {
        let listed: Vec<&str> = v["techniques"][k]["params"]
            .as_array()
            .map(|a| a.iter().filter_map(|p| p["name"].as_str()).collect())
            .unwrap_or_default();
        let declared: Vec<&str> = info.params.iter().map(|p| p.name.as_ref()).collect();
        ensure!(
            listed == declared,
            "{}: listed {listed:?}, declared {declared:?}",
            info.id
        );
    }
    // Every builtin scene, the stiff cases included.
    let builtin: Vec<String> = softshadow_scenes::builtin_scenes()
        .iter()
        .map(|s| s.id.to_string())
        .collect();
    ensure!(
        builtin.iter().filter(|id| id.starts_with("stiff-")).count() >= 15,
        "{builtin:?}"
    );
    for id in &builtin {
        ensure!(ids("scenes").contains(id), "list lacks scene {id}");
    }
    let scenes = ids("scenes");
    for s in [
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
    ] {
        ensure!(scenes.contains(&s.to_string()), "missing scene {s}");
    }
    let pcss = &v["techniques"][1];
    ensure!(
        pcss["params"][0]["min"].is_number(),
        "parameters carry ranges: {pcss}"
    );
    Ok(())
}

/// The plain `workbench list` a user reads: under "Scenes:" every builtin scene (every `stiff-*`
/// case among them) and under "Techniques:" every registered technique, in registry order, each
/// followed by its declared parameters.
#[test]
fn list_text_names_every_technique_with_its_parameters_and_every_stiff_scene() -> Result<()> {
    let o = workbench(&["list"]);
    ensure!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout)?;
    let (scenes, techniques) = text
        .split_once("\nTechniques:\n")
        .context("no `Techniques:` section")?;
    let scenes = scenes
        .strip_prefix("Scenes:\n")
        .context("no `Scenes:` section first")?;
    // An entry is a line indented by two spaces; its parameters are indented by six.
    let entries = |section: &str| -> Vec<(String, Vec<String>)> {
        let mut entries: Vec<(String, Vec<String>)> = Vec::new();
        for line in section.lines() {
            let first_word = || line.split_whitespace().next().unwrap_or("").to_string();
            if line.starts_with("      ") {
                if let Some(entry) = entries.last_mut() {
                    entry.1.push(first_word());
                }
            } else if line.starts_with("  ") {
                entries.push((first_word(), Vec::new()));
            }
        }
        entries
    };
    let listed_scenes: Vec<String> = entries(scenes).into_iter().map(|e| e.0).collect();
    let builtin: Vec<String> = softshadow_scenes::builtin_scenes()
        .iter()
        .map(|s| s.id.to_string())
        .collect();
    ensure!(
        listed_scenes == builtin,
        "list shows scenes {listed_scenes:?}, the builtin ones are {builtin:?}"
    );
    let stiff: Vec<&String> = listed_scenes
        .iter()
        .filter(|id| id.starts_with("stiff-"))
        .collect();
    ensure!(
        stiff.len() >= 15,
        "only {} stiff cases: {stiff:?}",
        stiff.len()
    );
    // The built-in paths come last (docs/SCENES.md, "Paths").
    let (techniques, paths) = techniques
        .split_once("\nPaths ")
        .context("no `Paths` section after the techniques")?;
    let listed_paths: Vec<String> = entries(paths).into_iter().map(|e| e.0).collect();
    let builtin_paths: Vec<String> = softshadow_scenes::path::BUILTIN_PATHS
        .iter()
        .map(|(name, _)| name.to_string())
        .collect();
    ensure!(
        listed_paths == builtin_paths,
        "list shows paths {listed_paths:?}, the built-in ones are {builtin_paths:?}"
    );
    let listed = entries(techniques);
    let registry = softshadow::registry();
    ensure!(
        listed.len() == registry.len(),
        "list shows {} techniques, the registry has {}",
        listed.len(),
        registry.len()
    );
    for ((id, params), info) in listed.iter().zip(&registry) {
        ensure!(
            *id == info.id,
            "list shows {id} where the registry has {}",
            info.id
        );
        let declared: Vec<&str> = info.params.iter().map(|p| p.name.as_ref()).collect();
        ensure!(
            *params == declared,
            "{id}: list shows parameters {params:?}, declared {declared:?}"
        );
    }
    Ok(())
}

#[test]
fn bench_writes_results_json_with_every_field_and_the_images() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("b");
    let out_s = out.to_str().context("utf-8 path")?;
    let o = workbench(&[
        "bench",
        "--scene",
        "atty-square",
        "--technique",
        "pcss",
        "--size",
        "64x64",
        "--frames",
        "3",
        "--reference-param",
        "samples_per_axis=8",
        "--out",
        out_s,
    ]);
    ensure!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(out.join("results.json"))?)?;
    ensure!(v["schema_version"] == 3);
    ensure!(
        run_source(&v) == "serial",
        "lavapipe is a CPU adapter: serial timing by default"
    );
    for k in ["name", "backend", "driver"] {
        ensure!(v["adapter"][k].is_string(), "adapter.{k}");
    }
    let run = &v["runs"][0];
    ensure!(run["status"] == "ok", "{run}");
    ensure!(run["timing"]["frames"] == 3);
    let gpu = run["timing"]["frame_ms"]["median"]
        .as_f64()
        .context("frame_ms.median")?;
    ensure!(gpu.is_finite() && gpu > 0.0, "frame_ms {gpu}");
    for k in ["p10", "p90"] {
        ensure!(
            run["timing"]["frame_ms"][k]
                .as_f64()
                .is_some_and(|x| x > 0.0),
            "frame_ms.{k}"
        );
    }
    ensure!(run["timing"]["cpu_ms"]["median"]
        .as_f64()
        .is_some_and(|x| x > 0.0));
    let passes: Vec<&str> = run["timing"]["passes"]
        .as_array()
        .context("passes")?
        .iter()
        .filter_map(|p| p["name"].as_str())
        .collect();
    ensure!(passes.contains(&"pcss/filter"), "{passes:?}");
    // The cold first frame builds the shadow map the camera-only frames keep.
    let cold_passes: Vec<&str> = run["cold"]["timing"]["passes_run"]
        .as_array()
        .context("cold.timing.passes_run")?
        .iter()
        .filter_map(|p| p.as_str())
        .collect();
    ensure!(cold_passes.contains(&"pcss/shadow_map"), "{cold_passes:?}");
    ensure!(run["cold"]["timing"]["frame_ms"]["median"]
        .as_f64()
        .is_some_and(|x| x > 0.0));
    ensure!(run["cold"]["stats"].is_object(), "cold.stats");
    for k in [
        "reference",
        "mae_shadowed",
        "mae_all",
        "rmse",
        "max_abs",
        "p99_abs",
        "shadowed_pixels",
        "flip_mean",
    ] {
        ensure!(
            !run["error"][k].is_null(),
            "error.{k} missing: {}",
            run["error"]
        );
    }
    for k in ["nan", "inf", "out_of_range"] {
        ensure!(run["stability"][k] == 0, "stability.{k}");
    }
    // Exact ground truth (issue 6): atty-square has the closed form; the reference's own error
    // against it is small and reported beside the technique's.
    ensure!(run["error"]["exact"] == "closed-form", "{}", run["error"]);
    ensure!(run["error"]["vs_exact"]["mae_all"].is_number());
    let own = run["error"]["reference_vs_exact"]["mae_shadowed"]
        .as_f64()
        .context("error.reference_vs_exact.mae_shadowed")?;
    ensure!(own < 0.05, "8x8 reference vs exact {own}");
    ensure!(run["passes_run"].as_array().is_some_and(|p| !p.is_empty()));
    for kind in ["visibility", "reference", "shaded", "difference", "exact"] {
        let file = run["images"][kind]
            .as_str()
            .with_context(|| format!("images.{kind}"))?;
        ensure!(out.join(file).is_file(), "{file} not written");
    }
    // The reference must not have leaked into the technique's passes.
    ensure!(
        !run["passes_run"].to_string().contains("reference"),
        "{}",
        run["passes_run"]
    );
    Ok(())
}

#[test]
fn bad_input_gives_one_line_a_nonzero_exit_and_no_output() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let malformed = dir.path().join("malformed.toml");
    std::fs::write(
        &malformed,
        "name = \"x\"\n[[object]]\nplane = { size = [1, 1] }\ncolour = 3\n",
    )?;
    let broken_glb = dir.path().join("broken.glb");
    std::fs::write(&broken_glb, b"glTF\x02\x00\x00\x00garbage")?;
    let malformed = malformed.to_str().context("utf-8")?;
    let broken_glb = broken_glb.to_str().context("utf-8")?;
    let cases: &[(&[&str], &str)] = &[
        (
            &["--scene", "no-such-scene", "--technique", "pcss"],
            "no-such-scene",
        ),
        (
            &["--scene", "atty-square", "--technique", "nope"],
            "unknown technique `nope`",
        ),
        (
            &[
                "--scene",
                "atty-square",
                "--technique",
                "pcss",
                "--param",
                "wat=1",
            ],
            "unknown parameter `wat`",
        ),
        (
            &[
                "--scene",
                "atty-square",
                "--technique",
                "pcss",
                "--param",
                "filter_samples=100000",
            ],
            "out of range",
        ),
        (
            &[
                "--scene",
                "atty-square",
                "--technique",
                "pcss",
                "--param",
                "bias_texels=NaN",
            ],
            "not finite",
        ),
        (
            &[
                "--scene",
                "atty-square",
                "--technique",
                "pcss",
                "--size",
                "0x64",
            ],
            "0x64",
        ),
        (
            &[
                "--scene",
                "atty-square",
                "--technique",
                "pcss",
                "--size",
                "100000x64",
            ],
            "100000x64",
        ),
        (
            &[
                "--scene",
                "atty-square",
                "--technique",
                "pcss",
                "--size",
                "big",
            ],
            "WIDTHxHEIGHT",
        ),
        (
            &["--scene", "/nonexistent/scene.toml", "--technique", "pcss"],
            "not found",
        ),
        (&["--scene", malformed, "--technique", "pcss"], "colour"),
        (&["--suite", "nope"], "unknown suite `nope`"),
        (
            &["--scene", broken_glb, "--technique", "pcss"],
            "broken.glb",
        ),
        (
            &[
                "--scene",
                "atty-square:light_width=NaN",
                "--technique",
                "pcss",
            ],
            "light_width",
        ),
        (
            &[
                "--scene",
                "atty-square",
                "--technique",
                "pcss",
                "--frames",
                "0",
            ],
            "frames",
        ),
    ];
    for (k, (args, expected)) in cases.iter().enumerate() {
        let out = dir.path().join(format!("out{k}"));
        let mut full = vec!["bench"];
        full.extend_from_slice(args);
        full.extend_from_slice(&["--out", out.to_str().context("utf-8")?]);
        let o = workbench(&full);
        let err = stderr(&o);
        ensure!(!o.status.success(), "{args:?} succeeded");
        ensure!(
            err.lines().count() == 1,
            "{args:?}: expected one line, got:\n{err}"
        );
        ensure!(
            err.contains(expected),
            "{args:?}: `{err}` does not mention `{expected}`"
        );
        ensure!(!out.exists(), "{args:?} wrote output");
    }
    Ok(())
}

#[test]
fn a_sweep_records_a_failed_run_and_keeps_the_others() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        "size = \"48x48\"\nframes = 1\nwarmup = 0\nscenes = [\"atty-square\", \"missing-file.toml\"]\n\
         [reference]\nsamples_per_axis = 4\n[[technique]]\nid = \"hard\"\n",
    )?;
    let out = dir.path().join("out");
    let o = workbench(&[
        "bench",
        "--sweep",
        sweep.to_str().context("utf-8")?,
        "--out",
        out.to_str().context("utf-8")?,
    ]);
    ensure!(
        o.status.code() == Some(3),
        "exit {:?}: {}",
        o.status.code(),
        stderr(&o)
    );
    let v: Value = serde_json::from_str(&std::fs::read_to_string(out.join("results.json"))?)?;
    let runs = v["runs"].as_array().context("runs")?;
    ensure!(runs.len() == 2);
    ensure!(runs[0]["status"] == "ok", "{}", runs[0]);
    ensure!(runs[1]["status"] == "error");
    ensure!(
        runs[1]["message"]
            .as_str()
            .is_some_and(|m| m.contains("missing-file.toml")),
        "{}",
        runs[1]
    );
    Ok(())
}

#[test]
fn no_adapter_says_what_to_install() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out");
    // No Metal adapter exists on Linux: this is the "no GPU" path.
    let o = Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args([
            "bench",
            "--scene",
            "atty-square",
            "--technique",
            "hard",
            "--out",
        ])
        .arg(&out)
        .env("WGPU_BACKEND", "metal")
        .output()?;
    let err = stderr(&o);
    ensure!(o.status.code() == Some(2), "{err}");
    ensure!(err.contains("mesa-vulkan-drivers"), "{err}");
    ensure!(!out.exists());
    Ok(())
}

/// `timing.source` of the first run.
fn run_source(results: &Value) -> &str {
    results["runs"][0]["timing"]["source"]
        .as_str()
        .unwrap_or("")
}

/// `examples/wgsl/NAME` by absolute path.
fn wgsl_example(name: &str) -> Result<String> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/wgsl")
        .join(name)
        .canonicalize()?;
    Ok(path.to_str().context("utf-8 path")?.to_string())
}

#[test]
fn bench_and_a_sweep_take_a_wgsl_file_as_a_technique() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let pcf = wgsl_example("pcf.wgsl")?;
    let out = dir.path().join("single");
    let o = workbench(&[
        "bench",
        "--scene",
        "atty-square",
        "--technique",
        &pcf,
        "--param",
        "radius=2",
        "--size",
        "48x48",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--no-images",
        "--reference-param",
        "samples_per_axis=4",
        "--out",
        out.to_str().context("utf-8")?,
    ]);
    ensure!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(out.join("results.json"))?)?;
    let run = &v["runs"][0];
    ensure!(run["status"] == "ok", "{run}");
    ensure!(run["technique"] == "pcf", "{}", run["technique"]);
    ensure!(run["params"]["radius"] == 2, "{}", run["params"]);
    ensure!(run["params"]["bias_texels"] == 1.5, "{}", run["params"]);

    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        format!(
            "size = \"32x32\"\nframes = 1\nwarmup = 0\nscenes = [\"atty-square\"]\n\
             [reference]\nsamples_per_axis = 4\n[[technique]]\nid = \"{}\"\n\
             [technique.params]\nsearch_grid = [2, 4]\n",
            wgsl_example("pcss_like.wgsl")?
        ),
    )?;
    let out = dir.path().join("sweep");
    let o = workbench(&[
        "bench",
        "--sweep",
        sweep.to_str().context("utf-8")?,
        "--no-images",
        "--out",
        out.to_str().context("utf-8")?,
    ]);
    ensure!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(out.join("results.json"))?)?;
    let runs = v["runs"].as_array().context("runs")?;
    ensure!(runs.len() == 2, "{runs:?}");
    for run in runs {
        ensure!(
            run["status"] == "ok" && run["technique"] == "pcss_like",
            "{run}"
        );
    }

    // A broken file: one line naming file, line and column, exit 2, nothing written.
    let broken = dir.path().join("broken.wgsl");
    std::fs::write(
        &broken,
        "fn visibility(s: Surface, pixel: vec2<i32>) -> f32 {\n    return 1.0\n}\n// @contract 3\n",
    )?;
    let out = dir.path().join("broken");
    let o = workbench(&[
        "bench",
        "--scene",
        "atty-square",
        "--technique",
        broken.to_str().context("utf-8")?,
        "--out",
        out.to_str().context("utf-8")?,
    ]);
    let message = stderr(&o);
    ensure!(o.status.code() == Some(2), "{message}");
    ensure!(message.lines().count() == 1, "{message}");
    ensure!(
        message.contains(&format!("{}:3:1:", broken.display())),
        "{message}"
    );
    ensure!(!out.exists(), "a broken technique file wrote output");
    Ok(())
}

/// On an adapter without ray queries (forced with `SOFTSHADOW_NO_RAY_QUERY=1`), `list` says on
/// the ray-traced technique's line that it is unavailable and what to install, `list --json`
/// gives the same line as `unavailable`, and `bench` records the run as an error with that line
/// in results.json and exits 3 (a run failed), as documented.
#[test]
fn without_ray_queries_list_and_bench_say_what_to_install() -> Result<()> {
    let info = softshadow::raytraced::info();
    let id = info.id.as_ref();
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_workbench"))
            .args(args)
            .env("SOFTSHADOW_NO_RAY_QUERY", "1")
            .output()
            .expect("the workbench binary runs")
    };
    let o = run(&["list"]);
    ensure!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout)?;
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with(id))
        .context("no line for the technique")?;
    ensure!(
        line.contains("unavailable: ") && line.contains("Mesa 24.1"),
        "{line}"
    );
    let o = run(&["list", "--json"]);
    let v: Value = serde_json::from_slice(&o.stdout)?;
    let entry = v["techniques"]
        .as_array()
        .and_then(|a| a.iter().find(|t| t["id"] == id))
        .context("technique in list --json")?;
    ensure!(
        entry["unavailable"]
            .as_str()
            .is_some_and(|m| m.contains("Mesa 24.1")),
        "{entry}"
    );
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out");
    let o = run(&[
        "bench",
        "--scene",
        "atty-square",
        "--technique",
        id,
        "--size",
        "32x32",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--no-images",
        "--no-camera-only",
        "--out",
        out.to_str().context("utf-8")?,
    ]);
    ensure!(
        o.status.code() == Some(3),
        "exit {:?}: {}",
        o.status.code(),
        stderr(&o)
    );
    let v: Value = serde_json::from_str(&std::fs::read_to_string(out.join("results.json"))?)?;
    let message = v["runs"][0]["message"].as_str().unwrap_or_default();
    ensure!(
        v["runs"][0]["status"] == "error" && message.contains("Mesa 24.1"),
        "{message}"
    );
    Ok(())
}

/// Light kinds (issue 39): `list --json` gives each technique's supported kinds; a single run of
/// a kind its technique does not support is refused in one line naming technique and kind (exit
/// 2, nothing written, no GPU work); a sweep records it as `unsupported` and goes on (exit 0).
#[test]
fn an_unsupported_light_kind_is_refused_and_recorded_by_a_sweep() -> Result<()> {
    let o = workbench(&["list", "--json"]);
    let v: Value = serde_json::from_slice(&o.stdout)?;
    for t in v["techniques"].as_array().context("techniques")? {
        let info = softshadow::registry()
            .get(t["id"].as_str().context("id")?)
            .context("registered")?
            .clone();
        let kinds: Vec<&str> = info
            .light_kinds
            .supported()
            .iter()
            .map(|k| k.name())
            .collect();
        ensure!(t["light_kinds"] == serde_json::json!(kinds), "{t}");
    }
    let dir = tempfile::tempdir()?;
    let scene = dir.path().join("sunlit.toml");
    std::fs::write(
        &scene,
        "[light]\nkind = \"sun\"\ndirection = [0.2, -1, 0.1]\nangular_diameter_degrees = 4\n\
         [[object]]\nplane = { size = [4, 4] }\ncasts_shadow = false\n\
         [[object]]\nbox = { size = [0.5, 0.5, 0.5] }\ntranslation = [0, 1, 0]\nreceives_shadow = false\n",
    )?;
    let scene = scene.to_str().context("utf-8")?;
    let out = dir.path().join("single");
    let o = workbench(&[
        "bench",
        "--scene",
        scene,
        "--technique",
        "ssm",
        "--out",
        out.to_str().context("utf-8")?,
    ]);
    let message = stderr(&o);
    ensure!(o.status.code() == Some(2), "{message}");
    ensure!(message.lines().count() == 1, "{message}");
    ensure!(
        message.contains("`ssm`") && message.contains("`sun`"),
        "{message}"
    );
    ensure!(!out.exists(), "a refused run wrote {}", out.display());

    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        format!(
            "size = \"32x32\"\nframes = 1\nwarmup = 0\nscenes = [\"{scene}\"]\n\
             [reference]\nsamples_per_axis = 2\n[[technique]]\nid = \"ssm\"\n[[technique]]\nid = \"raytraced\"\n"
        ),
    )?;
    let out = dir.path().join("sweep");
    let o = workbench(&[
        "bench",
        "--sweep",
        sweep.to_str().context("utf-8")?,
        "--no-error",
        "--out",
        out.to_str().context("utf-8")?,
    ]);
    ensure!(
        o.status.success(),
        "exit {:?}: {}",
        o.status.code(),
        stderr(&o)
    );
    let v: Value = serde_json::from_str(&std::fs::read_to_string(out.join("results.json"))?)?;
    let runs = v["runs"].as_array().context("runs")?;
    ensure!(runs.len() == 2, "{v}");
    ensure!(
        runs[0]["status"] == "unsupported" && runs[0]["light_kind"] == "sun",
        "{}",
        runs[0]
    );
    ensure!(
        runs[0]["message"]
            .as_str()
            .is_some_and(|m| m.contains("`ssm`")),
        "{}",
        runs[0]
    );
    ensure!(runs[1]["status"] == "ok", "{}", runs[1]);
    Ok(())
}
