//! Error against time: one point per technique and setting tried on the current scene, the
//! Pareto front (no other point is both faster and more accurate), and export of the points as a
//! benchmark sweep file (`workbench bench --sweep`).

use softshadow_core::{AreaLight, Camera, ParamValue};

/// One technique with one setting, measured on the current scene, light and camera.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TradeoffPoint {
    pub technique: String,
    /// The version of a technique defined by a WGSL file (1: the file as first loaded, one more
    /// per saved version that compiled); `None` for every other technique.
    pub version: Option<u32>,
    /// Every parameter with its value.
    pub params: Vec<(String, ParamValue)>,
    /// Median GPU time of the technique's own passes over its clean cost frames, ms.
    pub gpu_ms: f64,
    /// Fastest and slowest of those frames, ms.
    pub gpu_range: (f64, f64),
    /// Frames with the caches dropped that ran alone (no other frame on the device's CPU) and
    /// that `gpu_ms` rests on.
    pub cost_frames: usize,
    /// `mae_shadowed` against the converged reference.
    pub error: f64,
    /// For a technique that keeps a history (its descriptor's `varies_per_frame`): the error
    /// was measured after this many still frames, once its history had settled; `None`: of the
    /// frame as it is, which any frame of the setting repeats.
    pub settled_after: Option<u32>,
}

impl TradeoffPoint {
    /// The plot's series of the point: the technique id, with ` vN` for a file technique's
    /// version (`pcf v1`, `pcf v2`).
    pub fn series(&self) -> String {
        match self.version {
            Some(v) => format!("{} v{v}", self.technique),
            None => self.technique.clone(),
        }
    }

    /// `pcss(filter_samples=32, kernel=grid)`, non-default values only.
    pub fn label(&self, defaults: &[(String, ParamValue)]) -> String {
        let changed: Vec<String> = self
            .params
            .iter()
            .filter(|(name, value)| !defaults.iter().any(|(n, v)| n == name && v == value))
            .map(|(name, value)| format!("{name}={value}"))
            .collect();
        if changed.is_empty() {
            self.series()
        } else {
            format!("{}({})", self.series(), changed.join(", "))
        }
    }

    /// Same technique, version and settings (the time and error may differ).
    pub fn same_setting(&self, other: &TradeoffPoint) -> bool {
        self.technique == other.technique
            && self.version == other.version
            && self.params == other.params
    }
}

/// Indices of the points on the Pareto front, fastest first: a point is on it when no other point
/// is at least as fast and at least as accurate, and strictly better in one of the two.
pub fn pareto_front(points: &[TradeoffPoint]) -> Vec<usize> {
    let dominated = |i: usize| {
        let p = &points[i];
        points.iter().any(|q| {
            q.gpu_ms <= p.gpu_ms && q.error <= p.error && (q.gpu_ms < p.gpu_ms || q.error < p.error)
        })
    };
    let mut front: Vec<usize> = (0..points.len()).filter(|&i| !dominated(i)).collect();
    front.sort_by(|&a, &b| points[a].gpu_ms.total_cmp(&points[b].gpu_ms));
    front
}

/// The viewer's view of the scene: what a benchmark of an exported sweep must look at.
#[derive(Clone, Copy, Debug)]
pub struct View<'a> {
    pub scene: &'a str,
    pub width: u32,
    pub height: u32,
    pub camera: &'a Camera,
    pub light: &'a AreaLight,
}

/// The points as a sweep file: the scene, the image size, the camera and light, and one
/// `[[technique]]` table per point with every parameter as a single value (so each table is
/// exactly one run).
pub fn sweep_toml(
    points: &[TradeoffPoint],
    view: View<'_>,
    reference_params: &[(String, ParamValue)],
) -> String {
    let View {
        scene,
        width,
        height,
        camera,
        light,
    } = view;
    let mut out = String::from("# Exported by the viewer: one run per technique setting tried.\n");
    out.push_str(&format!("size = \"{width}x{height}\"\n"));
    out.push_str(&format!("scenes = [{}]\n", toml_string(scene)));
    if !reference_params.is_empty() {
        out.push_str("\n[reference]\n");
        for (name, value) in reference_params {
            out.push_str(&format!("{name} = {}\n", toml_value(value)));
        }
    }
    // The view the points were measured from (the scene's own camera and light may differ).
    for (table, body) in [
        ("camera", toml::to_string(camera)),
        ("light", toml::to_string(light)),
    ] {
        // Plain numbers and arrays of numbers: serialising cannot fail.
        let body = body.unwrap_or_default();
        out.push_str(&format!("\n[{table}]\n{body}"));
    }
    for point in points {
        let settled = point
            .settled_after
            .map_or(String::new(), |n| format!(" (settled after {n} frames)"));
        out.push_str(&format!(
            "\n# gpu {:.3} ms, mae_shadowed {:.5}{settled}\n[[technique]]\nid = {}\n",
            point.gpu_ms,
            point.error,
            toml_string(&point.technique)
        ));
        if !point.params.is_empty() {
            out.push_str("[technique.params]\n");
            for (name, value) in &point.params {
                out.push_str(&format!("{name} = {}\n", toml_value(value)));
            }
        }
    }
    out
}

fn toml_value(value: &ParamValue) -> String {
    match value {
        ParamValue::Bool(b) => b.to_string(),
        ParamValue::Int(i) => i.to_string(),
        // `{:?}` keeps a decimal point, so TOML reads a float back.
        ParamValue::Float(x) => format!("{x:?}"),
        ParamValue::Choice(s) => toml_string(s),
    }
}

fn toml_string(text: &str) -> String {
    toml::Value::String(text.to_string()).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(technique: &str, gpu_ms: f64, error: f64) -> TradeoffPoint {
        TradeoffPoint {
            technique: technique.into(),
            params: vec![
                ("filter_samples".into(), ParamValue::Int(gpu_ms as i64)),
                ("kernel".into(), ParamValue::Choice("grid".into())),
                ("bias_texels".into(), ParamValue::Float(1.0)),
            ],
            gpu_ms,
            gpu_range: (gpu_ms, gpu_ms),
            cost_frames: 5,
            error,
            version: None,
            settled_after: None,
        }
    }

    #[test]
    fn the_front_keeps_only_undominated_points_fastest_first() {
        let points = vec![
            point("pcss", 30.0, 0.05),
            point("pcss", 10.0, 0.20),
            point("pcss", 40.0, 0.06), // slower and worse than the first
            point("pcss", 20.0, 0.05), // dominates the first
        ];
        assert_eq!(pareto_front(&points), vec![1, 3]);
        assert!(pareto_front(&[]).is_empty());
    }

    #[test]
    fn exported_sweep_parses_back_into_one_run_per_point() {
        let points = vec![point("pcss", 16.0, 0.05), point("pcss", 32.0, 0.03)];
        let camera = Camera {
            fov_y_degrees: 38.5,
            ..Camera::default()
        };
        let light = AreaLight {
            width: 1.25,
            ..AreaLight::default()
        };
        let text = sweep_toml(
            &points,
            View {
                scene: "atty-square",
                width: 320,
                height: 180,
                camera: &camera,
                light: &light,
            },
            &[("samples_per_axis".into(), ParamValue::Int(8))],
        );
        let sweep = softshadow_bench::Sweep::parse(&text, &softshadow::registry()).expect(&text);
        assert_eq!(sweep.camera, Some(camera), "{text}");
        assert_eq!(sweep.light, Some(light), "{text}");
        assert_eq!(sweep.runs.len(), 2);
        assert_eq!(sweep.runs[1].params.len(), 3);
        assert_eq!((sweep.runs[0].width, sweep.runs[0].height), (320, 180));
        assert_eq!(sweep.reference_params.len(), 1);
        assert_eq!(
            points[1].label(&[("kernel".into(), ParamValue::Choice("grid".into()))]),
            "pcss(filter_samples=32, bias_texels=1)"
        );
    }
}
