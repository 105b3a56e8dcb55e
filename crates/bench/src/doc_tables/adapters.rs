//! The table kinds that compare adapters or read the figures issue 41 added: CPU against GPU
//! frame times, how rankings move, timestamps against serial timing, the resolution series,
//! millisecond budgets, memory and settled error ([`crate::compare`] computes them).

use std::fmt::Write as _;

use softshadow_core::COST_FLOOR_TECHNIQUE;

use super::varying_params;
use crate::{
    report::{frame_time_ms, mae_shadowed, ms, scenes_of},
    results::{Run, Status},
};

pub(super) fn cpu_gpu_table(cpu: &[Run], gpu: &[Run]) -> String {
    let mut t = String::from(
        "| technique | settings that differ | scenes | CPU frame ms (median) | GPU frame ms (median) | CPU / GPU |\n|---|---|---|---|---|---|\n",
    );
    for pair in crate::compare::setting_pairs(cpu, gpu) {
        let _ = writeln!(
            t,
            "| `{}` | {} | {} | {} | {} | {:.0}x |",
            pair.technique,
            pair.params,
            pair.scenes,
            ms(pair.cpu_ms),
            ms(pair.gpu_ms),
            pair.cpu_ms / pair.gpu_ms
        );
    }
    t
}

pub(super) fn rank_moves_table(cpu: &[Run], gpu: &[Run]) -> String {
    let mut t = String::from(
        "| scene | settings | rank correlation of frame times (Spearman) |\n|---|---|---|\n",
    );
    for m in crate::compare::scene_rank_moves(cpu, gpu) {
        let _ = writeln!(
            t,
            "| `{}` | {} | {} |",
            m.scene,
            m.settings,
            m.frame_time_rho.map_or("-".into(), |r| format!("{r:.2}"))
        );
    }
    let _ = write!(
        t,
        "\n| technique | mean rank, CPU | mean rank, GPU | change | frame / `{COST_FLOOR_TECHNIQUE}`'s, CPU | frame / `{COST_FLOOR_TECHNIQUE}`'s, GPU |\n|---|---|---|---|---|---|\n"
    );
    let num = |v: Option<f64>, digits: usize| v.map_or("-".into(), |v| format!("{v:.digits$}"));
    for m in crate::compare::technique_moves(cpu, gpu) {
        let _ = writeln!(
            t,
            "| `{}` | {} | {} | {} | {} | {} |",
            m.technique,
            num(m.cpu_mean_rank, 1),
            num(m.gpu_mean_rank, 1),
            m.rank_change().map_or("-".into(), |c| format!("{c:+.1}")),
            num(m.cpu_floor_ratio, 1),
            num(m.gpu_floor_ratio, 1)
        );
    }
    t
}

pub(super) fn timestamps_table(runs: &[Run]) -> String {
    let mut t = String::from(
        "| technique | runs | its passes, timestamps (ms, median) | the same passes one by one, serial (ms, median) | serial / timestamps |\n|---|---|---|---|---|\n",
    );
    for row in crate::compare::timestamps_against_serial(runs) {
        let _ = writeln!(
            t,
            "| `{}` | {} | {} | {} | {:.1} |",
            row.technique,
            row.runs,
            ms(row.timestamps_ms),
            ms(row.serial_ms),
            row.serial_ms / row.timestamps_ms
        );
    }
    t
}

pub(super) fn pass_timestamps_table(runs: &[Run]) -> String {
    let mut t = String::from(
        "| pass | runs | timestamps (ms, median) | serial (ms, median) | serial / timestamps |\n|---|---|---|---|---|\n",
    );
    for row in crate::compare::passes_against_serial(runs) {
        let _ = writeln!(
            t,
            "| `{}` | {} | {} | {} | {:.1} |",
            row.pass,
            row.runs,
            ms(row.timestamps_ms),
            ms(row.serial_ms),
            row.serial_ms / row.timestamps_ms
        );
    }
    t
}

pub(super) fn resolution_table(runs: &[Run]) -> String {
    let (sizes, rows) = crate::compare::resolution_series(runs);
    let mut t = String::from("| technique, settings that differ |");
    for (w, h) in &sizes {
        let _ = write!(t, " {w}x{h} ms |");
    }
    t.push_str(" last / first |\n|---|");
    t.push_str(&"---|".repeat(sizes.len() + 1));
    t.push('\n');
    for (setting, cells) in rows {
        let _ = write!(t, "| `{setting}` |");
        for cell in &cells {
            let _ = write!(t, " {} |", cell.map_or("failed".into(), ms));
        }
        let growth = match (
            cells.first().copied().flatten(),
            cells.last().copied().flatten(),
        ) {
            (Some(a), Some(b)) => format!("{:.1}x", b / a),
            _ => "-".into(),
        };
        let _ = writeln!(t, " {growth} |");
    }
    t
}

pub(super) fn ms_budgets_table(runs: &[Run]) -> String {
    use crate::report::{ms_budget_scenes, summary_rows_within, Budgets, Score};
    let scenes = ms_budget_scenes(runs, &scenes_of(runs));
    let rows = summary_rows_within(runs, &scenes, Budgets::Milliseconds, Score::Visibility);
    super::across_scenes_table(&rows, scenes.len(), Budgets::Milliseconds)
}

pub(super) fn memory_table(runs: &[Run]) -> String {
    let measured: Vec<&Run> = runs
        .iter()
        .filter(|r| r.status == Status::Ok && r.memory.is_some() && r.motion.is_none())
        .collect();
    let mut rows: Vec<(String, String)> = Vec::new();
    for run in &measured {
        let row = (run.technique.clone(), varying_params(run, &measured));
        if !rows.contains(&row) {
            rows.push(row);
        }
    }
    let mut t = String::from(
        "| technique | settings that differ | GPU memory after its frames, MiB | at its peak, MiB | of it textures | mae_shadowed (median over scenes) |\n|---|---|---|---|---|---|\n",
    );
    for (technique, params) in rows {
        let of_row: Vec<&&Run> = measured
            .iter()
            .filter(|r| r.technique == technique && varying_params(r, &measured) == params)
            .collect();
        let memory = |f: &dyn Fn(&crate::results::TechniqueMemory) -> f64| {
            let mut v: Vec<f64> = of_row
                .iter()
                .filter_map(|r| Some(f(r.memory.as_ref()?)))
                .collect();
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
        };
        let mut errors: Vec<f64> = of_row.iter().filter_map(|r| mae_shadowed(r)).collect();
        errors.sort_by(f64::total_cmp);
        let peak = memory(&|m| m.peak.total_mib());
        let _ = writeln!(
            t,
            "| `{technique}` | {params} | {:.1} | {peak:.1} | {:.0} % | {} |",
            memory(&|m| m.current.total_mib()),
            100.0 * memory(&|m| m.peak.textures as f64 / m.peak.total().max(1) as f64),
            errors
                .get(errors.len() / 2)
                .map_or("-".into(), |e| format!("{e:.4}"))
        );
    }
    t
}

pub(super) fn settled_table(runs: &[Run]) -> String {
    let settled: Vec<&Run> = runs
        .iter()
        .filter(|r| r.status == Status::Ok && r.settled.is_some())
        .collect();
    let mut t = String::from(
        "| scene | technique | settings that differ | mae_shadowed, first frame | settled | after frames | frame ms, first (caches dropped) | frame ms, settled |\n|---|---|---|---|---|---|---|---|\n",
    );
    for run in &settled {
        let s = run.settled.as_ref().expect("filtered");
        let settled_ms = s.timing.frame_ms.as_ref().map(|p| p.median);
        let _ = writeln!(
            t,
            "| `{}` | `{}` | {} | {} | {} | {} | {} | {} |",
            run.scene,
            run.technique,
            varying_params(run, &settled),
            mae_shadowed(run).map_or("-".into(), |e| format!("{e:.4}")),
            crate::report::scored_mae(run).map_or("-".into(), |e| format!("{e:.4}")),
            s.frames,
            frame_time_ms(run).map_or("-".into(), ms),
            settled_ms.map_or("-".into(), ms)
        );
    }
    t
}
