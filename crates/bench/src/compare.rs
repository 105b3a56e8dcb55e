//! The same runs on two adapters (a CPU's lavapipe and a GPU, docs/BENCHMARKS.md "On a GPU"):
//! frame times side by side, how each scene's ranking of techniques moves, and, within one
//! adapter, timestamp against serial pass times and frame time against image size. Runs are
//! matched by scene, technique, size and parameters.

use std::collections::BTreeMap;

use softshadow_core::TimingSource;

use crate::{
    report::{frame_time_ms, params_text, scenes_of, summary_rows},
    results::{Run, Status},
};

/// One technique setting on two adapters: the median of its frame times over the scenes both ran.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingPair {
    pub technique: String,
    /// The parameters that differ between the technique's runs.
    pub params: String,
    /// Scenes measured on both.
    pub scenes: usize,
    pub cpu_ms: f64,
    pub gpu_ms: f64,
}

fn key(run: &Run) -> (String, String, String, u32, u32) {
    (
        run.scene.clone(),
        run.technique.clone(),
        params_text(run),
        run.width,
        run.height,
    )
}

fn timed(runs: &[Run]) -> BTreeMap<(String, String, String, u32, u32), f64> {
    runs.iter()
        .filter(|r| r.status == Status::Ok && r.motion.is_none())
        .filter_map(|r| Some((key(r), frame_time_ms(r)?)))
        .collect()
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// Every setting measured on both, in the CPU runs' order.
pub fn setting_pairs(cpu: &[Run], gpu: &[Run]) -> Vec<SettingPair> {
    let (cpu_ms, gpu_ms) = (timed(cpu), timed(gpu));
    let mut order: Vec<(String, String)> = Vec::new();
    let mut times: BTreeMap<(String, String), (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for (k, c) in &cpu_ms {
        let Some(g) = gpu_ms.get(k) else { continue };
        let setting = (k.1.clone(), k.2.clone());
        if !order.contains(&setting) {
            order.push(setting.clone());
        }
        let entry = times.entry(setting).or_default();
        entry.0.push(*c);
        entry.1.push(*g);
    }
    let first_seen = |s: &(String, String)| {
        cpu.iter()
            .position(|r| r.technique == s.0 && params_text(r) == s.1)
    };
    order.sort_by_key(first_seen);
    let all: Vec<&Run> = cpu.iter().collect();
    order
        .into_iter()
        .map(|s| {
            let (c, g) = times.remove(&s).unwrap_or_default();
            let run = first_seen(&s).map(|i| &cpu[i]);
            SettingPair {
                scenes: c.len(),
                cpu_ms: median(c),
                gpu_ms: median(g),
                params: run.map_or(s.1.clone(), |r| crate::doc_tables::varying_params(r, &all)),
                technique: s.0,
            }
        })
        .collect()
}

/// Spearman's rank correlation of two equally long samples (average ranks for ties); `None`
/// for fewer than three values or a constant sample.
pub fn spearman(a: &[f64], b: &[f64]) -> Option<f64> {
    if a.len() != b.len() || a.len() < 3 {
        return None;
    }
    let (ra, rb) = (ranks(a), ranks(b));
    let mean = (a.len() as f64 + 1.0) / 2.0;
    let (mut num, mut da, mut db) = (0.0, 0.0, 0.0);
    for (x, y) in ra.iter().zip(&rb) {
        num += (x - mean) * (y - mean);
        da += (x - mean).powi(2);
        db += (y - mean).powi(2);
    }
    (da > 0.0 && db > 0.0).then(|| num / (da * db).sqrt())
}

/// 1-based ranks, ties sharing their average rank.
fn ranks(values: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&i, &j| values[i].total_cmp(&values[j]));
    let mut out = vec![0.0; values.len()];
    let mut k = 0;
    while k < order.len() {
        let mut end = k;
        while end + 1 < order.len() && values[order[end + 1]] == values[order[k]] {
            end += 1;
        }
        let rank = (k + end) as f64 / 2.0 + 1.0;
        for &i in &order[k..=end] {
            out[i] = rank;
        }
        k = end + 1;
    }
    out
}

/// How one scene's order of settings by frame time moves from the CPU to the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneRankMove {
    pub scene: String,
    /// Settings measured on both.
    pub settings: usize,
    /// Spearman's correlation of their frame times on the two adapters (1: the same order).
    pub frame_time_rho: Option<f64>,
}

/// Per scene (with its size): the Spearman correlation of the settings' frame times.
pub fn scene_rank_moves(cpu: &[Run], gpu: &[Run]) -> Vec<SceneRankMove> {
    let (cpu_ms, gpu_ms) = (timed(cpu), timed(gpu));
    scenes_of(cpu)
        .into_iter()
        .filter_map(|(scene, width, height)| {
            let (a, b): (Vec<f64>, Vec<f64>) = cpu_ms
                .iter()
                .filter(|(k, _)| k.0 == scene && k.3 == width && k.4 == height)
                .filter_map(|(k, c)| Some((*c, *gpu_ms.get(k)?)))
                .unzip();
            (!a.is_empty()).then(|| SceneRankMove {
                scene,
                settings: a.len(),
                frame_time_rho: spearman(&a, &b),
            })
        })
        .collect()
}

/// One technique's standing across scenes on each adapter (the report's summary: mean rank by
/// lowest error within multiples of the cost floor) and its frame time over the cost floor's.
#[derive(Clone, Debug, PartialEq)]
pub struct TechniqueMove {
    pub technique: String,
    pub cpu_mean_rank: Option<f64>,
    pub gpu_mean_rank: Option<f64>,
    /// Median over the scenes of its fastest setting's frame time over the cost floor's.
    pub cpu_floor_ratio: Option<f64>,
    pub gpu_floor_ratio: Option<f64>,
}

impl TechniqueMove {
    /// How far its mean rank moved (GPU minus CPU; negative: better on the GPU).
    pub fn rank_change(&self) -> Option<f64> {
        Some(self.gpu_mean_rank? - self.cpu_mean_rank?)
    }
}

/// Per technique, the summary's mean rank and frame time over the cost floor on each adapter,
/// over the scenes both ran; the techniques that move most first.
pub fn technique_moves(cpu: &[Run], gpu: &[Run]) -> Vec<TechniqueMove> {
    let gpu_scenes = scenes_of(gpu);
    let scenes: Vec<_> = scenes_of(cpu)
        .into_iter()
        .filter(|s| gpu_scenes.contains(s))
        .collect();
    let (cpu_rows, gpu_rows) = (summary_rows(cpu, &scenes), summary_rows(gpu, &scenes));
    let mut moves: Vec<TechniqueMove> = cpu_rows
        .iter()
        .map(|c| TechniqueMove {
            technique: c.technique.clone(),
            cpu_mean_rank: c.mean_rank,
            gpu_mean_rank: gpu_rows
                .iter()
                .find(|g| g.technique == c.technique)
                .and_then(|g| g.mean_rank),
            cpu_floor_ratio: floor_ratio(cpu, &c.technique, &scenes),
            gpu_floor_ratio: floor_ratio(gpu, &c.technique, &scenes),
        })
        .collect();
    moves.sort_by(|a, b| {
        let change = |m: &TechniqueMove| m.rank_change().map_or(-1.0, f64::abs);
        change(b).total_cmp(&change(a))
    });
    moves
}

/// Median over `scenes` of `technique`'s fastest frame time over the cost floor's fastest.
fn floor_ratio(runs: &[Run], technique: &str, scenes: &[(String, u32, u32)]) -> Option<f64> {
    let fastest = |scene: &(String, u32, u32), id: &str| -> Option<f64> {
        runs.iter()
            .filter(|r| r.status == Status::Ok && r.technique == id)
            .filter(|r| r.scene == scene.0 && r.width == scene.1 && r.height == scene.2)
            .filter_map(frame_time_ms)
            .reduce(f64::min)
    };
    let ratios: Vec<f64> = scenes
        .iter()
        .filter_map(|s| {
            Some(fastest(s, technique)? / fastest(s, softshadow_core::COST_FLOOR_TECHNIQUE)?)
        })
        .collect();
    (!ratios.is_empty()).then(|| median(ratios))
}

/// One technique's passes timed both ways on one adapter: the median over its runs of the
/// sum of its own passes' timestamp times and of the same passes' serial times (one
/// calibration frame each).
#[derive(Clone, Debug, PartialEq)]
pub struct TimestampsAgainstSerial {
    pub technique: String,
    pub runs: usize,
    pub timestamps_ms: f64,
    pub serial_ms: f64,
}

/// Per technique (first-seen order), runs timed with timestamps that carry serial pass times.
pub fn timestamps_against_serial(runs: &[Run]) -> Vec<TimestampsAgainstSerial> {
    let mut order: Vec<&str> = Vec::new();
    let mut sums: BTreeMap<&str, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for run in runs.iter().filter(|r| r.status == Status::Ok) {
        let Some(timing) = &run.timing else { continue };
        if timing.source != TimingSource::Timestamps {
            continue;
        }
        let own = |name: &str| name.starts_with(&format!("{}/", run.technique));
        let passes: Vec<_> = timing.passes.iter().filter(|p| own(&p.name)).collect();
        if passes.is_empty() || passes.iter().any(|p| p.serial_ms.is_none()) {
            continue;
        }
        if !order.contains(&run.technique.as_str()) {
            order.push(&run.technique);
        }
        let entry = sums.entry(&run.technique).or_default();
        entry.0.push(passes.iter().map(|p| p.ms_median).sum());
        entry
            .1
            .push(passes.iter().filter_map(|p| p.serial_ms).sum());
    }
    order
        .into_iter()
        .map(|t| {
            let (stamps, serial) = sums.remove(t).unwrap_or_default();
            TimestampsAgainstSerial {
                technique: t.to_string(),
                runs: stamps.len(),
                timestamps_ms: median(stamps),
                serial_ms: median(serial),
            }
        })
        .collect()
}

/// One setting's row of a resolution series: its label and, per size, its median frame time
/// (`None`: no run at that size finished).
pub type SeriesRow = (String, Vec<Option<f64>>);

/// One pass timed both ways on one adapter, over every run that ran it: the median of its
/// timestamp times and of its serial times (each run's calibration frame).
#[derive(Clone, Debug, PartialEq)]
pub struct PassAgainstSerial {
    pub pass: String,
    pub runs: usize,
    pub timestamps_ms: f64,
    pub serial_ms: f64,
}

/// Per pass name (first-seen order), the runs timed with timestamps that carry its serial time.
pub fn passes_against_serial(runs: &[Run]) -> Vec<PassAgainstSerial> {
    let mut order: Vec<&str> = Vec::new();
    let mut times: BTreeMap<&str, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for run in runs.iter().filter(|r| r.status == Status::Ok) {
        let Some(timing) = &run.timing else { continue };
        if timing.source != TimingSource::Timestamps {
            continue;
        }
        for pass in &timing.passes {
            let Some(serial) = pass.serial_ms else {
                continue;
            };
            if !order.contains(&pass.name.as_str()) {
                order.push(&pass.name);
            }
            let entry = times.entry(&pass.name).or_default();
            entry.0.push(pass.ms_median);
            entry.1.push(serial);
        }
    }
    order
        .into_iter()
        .map(|name| {
            let (stamps, serial) = times.remove(name).unwrap_or_default();
            PassAgainstSerial {
                pass: name.to_string(),
                runs: stamps.len(),
                timestamps_ms: median(stamps),
                serial_ms: median(serial),
            }
        })
        .collect()
}

/// Frame time per setting and image size (a sweep with `sizes`): rows of settings in run
/// order, columns the sizes in run order, each cell the median over the scenes.
pub fn resolution_series(runs: &[Run]) -> (Vec<(u32, u32)>, Vec<SeriesRow>) {
    let mut sizes: Vec<(u32, u32)> = Vec::new();
    let mut settings: Vec<String> = Vec::new();
    let all: Vec<&Run> = runs.iter().filter(|r| r.motion.is_none()).collect();
    for run in &all {
        if !sizes.contains(&(run.width, run.height)) {
            sizes.push((run.width, run.height));
        }
        let setting = setting_label(run, &all);
        if !settings.contains(&setting) {
            settings.push(setting);
        }
    }
    let rows = settings
        .into_iter()
        .map(|setting| {
            let cells = sizes
                .iter()
                .map(|&(w, h)| {
                    let times: Vec<f64> = runs
                        .iter()
                        .filter(|r| r.status == Status::Ok && r.width == w && r.height == h)
                        .filter(|r| setting_label(r, &all) == setting)
                        .filter_map(frame_time_ms)
                        .collect();
                    (!times.is_empty()).then(|| median(times))
                })
                .collect();
            (setting, cells)
        })
        .collect();
    (sizes, rows)
}

/// `technique a=1`: the technique and the parameters that differ between its runs in `runs`.
fn setting_label(run: &Run, runs: &[&Run]) -> String {
    let varying = crate::doc_tables::varying_params(run, runs);
    format!("{} {varying}", run.technique)
        .trim_end()
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spearman_is_one_for_the_same_order_and_minus_one_reversed() {
        let a = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(spearman(&a, &[10.0, 20.0, 30.0, 40.0]), Some(1.0));
        assert_eq!(spearman(&a, &[4.0, 3.0, 2.0, 1.0]), Some(-1.0));
        assert_eq!(spearman(&a, &[1.0, 1.0, 1.0, 1.0]), None);
        assert_eq!(ranks(&[5.0, 1.0, 5.0]), vec![2.5, 1.0, 2.5]);
        // Two adjacent settings swapped in six: 1 - 6 * 2 / (6 * 35).
        let rho = spearman(&[1., 2., 3., 4., 5., 6.], &[2., 1., 3., 4., 5., 6.]).unwrap();
        assert!((rho - (1.0 - 12.0 / 210.0)).abs() < 1e-12);
    }
}
