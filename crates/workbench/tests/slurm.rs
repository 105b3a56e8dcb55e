//! docs/CLUSTER.md's sharded sweeps, run for real: a one-node Slurm (Debian's `slurm-wlm`, with
//! its own `munged`) is started for the test in a temporary folder and `sweeps/overview-slurm.sh`
//! is submitted as a three-task array over a small sweep; `sweeps/overview-parallel.sh` runs the
//! same sweep as two shards with GNU parallel. The merged shards must give the same errors as the
//! sweep run in one piece. The Kubernetes Indexed Job file is checked for what can be checked
//! without a cluster. `.ci/run` installs `slurm-wlm`, `munge` and `parallel`.

use std::{
    net::TcpListener,
    path::{Path, PathBuf},
    process::{Child, Command, Stdio},
    time::{Duration, Instant},
};

use anyhow::{bail, ensure, Context, Result};
use serde_json::Value;

const WORKBENCH: &str = env!("CARGO_BIN_EXE_workbench");

/// Six runs: two scenes x (one `hard`, two `pcss` settings).
const SWEEP: &str = r#"
size = "32x32"
frames = 1
warmup = 0
scenes = ["atty-square", "stiff-fusion"]

[reference]
samples_per_axis = 4

[[technique]]
id = "hard"

[[technique]]
id = "pcss"
params = { filter_samples = [16, 32] }
"#;

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn found(program: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {program}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

fn output(program: &str, args: &[&str], conf: &Path) -> Result<String> {
    let out = Command::new(program)
        .args(args)
        .env("SLURM_CONF", conf)
        .output()
        .with_context(|| format!("running {program}"))?;
    ensure!(
        out.status.success(),
        "`{program} {}` failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    Ok(String::from_utf8(out.stdout)?)
}

fn free_port() -> Result<u16> {
    Ok(TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// A one-node Slurm of its own (controller, node daemon, munge), stopped when dropped.
struct LocalSlurm {
    dir: tempfile::TempDir,
    conf: PathBuf,
    daemons: Vec<Child>,
}

impl LocalSlurm {
    fn start() -> Result<Self> {
        for program in ["munged", "slurmctld", "slurmd", "sbatch", "sinfo"] {
            ensure!(
                found(program),
                "`{program}` not found: this test starts a one-node Slurm; install it with `apt-get install -y slurm-wlm munge` (.ci/run does)"
            );
        }
        let dir = tempfile::tempdir()?;
        let path = dir.path();
        for sub in ["state", "spool", "log"] {
            std::fs::create_dir_all(path.join(sub))?;
        }
        let key = path.join("munge.key");
        let bytes: Vec<u8> = (0..1024u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        std::fs::write(&key, bytes)?;
        std::fs::set_permissions(&key, std::os::unix::fs::PermissionsExt::from_mode(0o400))?;
        let socket = path.join("munge.socket");
        let munged = Command::new("munged")
            .arg("--force")
            .arg("--foreground")
            .arg(format!("--key-file={}", key.display()))
            .arg(format!("--socket={}", socket.display()))
            .arg(format!("--pid-file={}", path.join("munged.pid").display()))
            .arg(format!(
                "--log-file={}",
                path.join("log/munged.log").display()
            ))
            .arg(format!("--seed-file={}", path.join("munge.seed").display()))
            .spawn()
            .context("starting munged")?;
        let mut slurm = Self {
            conf: path.join("slurm.conf"),
            dir,
            daemons: vec![munged],
        };
        let host = std::fs::read_to_string("/proc/sys/kernel/hostname")?
            .trim()
            .to_string();
        // The node offers most of the machine's memory, so the script's `--mem` can be met.
        let meminfo = std::fs::read_to_string("/proc/meminfo")?;
        let total_kib: u64 = meminfo
            .lines()
            .find_map(|l| l.strip_prefix("MemTotal:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
            .context("MemTotal in /proc/meminfo")?;
        let memory_mib = total_kib / 1024 * 9 / 10;
        let user = output("id", &["-un"], &slurm.conf)?.trim().to_string();
        let path = slurm.dir.path();
        let conf = format!(
            "ClusterName=softshadow-test\n\
             SlurmctldHost={host}\n\
             SlurmUser={user}\n\
             SlurmdUser={user}\n\
             SlurmctldPort={ctld}\n\
             SlurmdPort={slurmd}\n\
             AuthType=auth/munge\n\
             AuthInfo=socket={socket}\n\
             CredType=cred/munge\n\
             StateSaveLocation={state}\n\
             SlurmdSpoolDir={spool}\n\
             SlurmctldPidFile={dir}/slurmctld.pid\n\
             SlurmdPidFile={dir}/slurmd.pid\n\
             SlurmctldLogFile={dir}/log/slurmctld.log\n\
             SlurmdLogFile={dir}/log/slurmd.log\n\
             ProctrackType=proctrack/linuxproc\n\
             TaskPlugin=task/none\n\
             SchedulerType=sched/builtin\n\
             SelectType=select/cons_tres\n\
             SelectTypeParameters=CR_Core\n\
             ReturnToService=2\n\
             MpiDefault=none\n\
             JobAcctGatherType=jobacct_gather/none\n\
             AccountingStorageType=accounting_storage/none\n\
             NodeName={host} CPUs=2 RealMemory={memory_mib} State=UNKNOWN\n\
             PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP OverSubscribe=FORCE:4\n",
            ctld = free_port()?,
            slurmd = free_port()?,
            socket = socket.display(),
            state = path.join("state").display(),
            spool = path.join("spool").display(),
            dir = path.display(),
        );
        std::fs::write(&slurm.conf, conf)?;
        for daemon in ["slurmctld", "slurmd"] {
            let child = Command::new(daemon)
                .arg("-D")
                .arg("-f")
                .arg(&slurm.conf)
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .with_context(|| format!("starting {daemon}"))?;
            slurm.daemons.push(child);
        }
        // The node registers with the controller within a few seconds.
        let start = Instant::now();
        loop {
            let state = output("sinfo", &["-h", "-o", "%T"], &slurm.conf).unwrap_or_default();
            if state.trim() == "idle" {
                return Ok(slurm);
            }
            if start.elapsed() > Duration::from_secs(60) {
                bail!(
                    "the local Slurm node is not idle after 60 s (sinfo: {:?}); logs in {}",
                    state.trim(),
                    slurm.dir.path().join("log").display()
                );
            }
            std::thread::sleep(Duration::from_millis(500));
        }
    }
}

impl Drop for LocalSlurm {
    fn drop(&mut self) {
        let _ = Command::new("scancel")
            .arg("--full")
            .arg("--user")
            .arg(std::env::var("USER").unwrap_or_else(|_| "root".into()))
            .env("SLURM_CONF", &self.conf)
            .status();
        for child in self.daemons.iter_mut().rev() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

fn workbench(args: &[&str]) -> Result<()> {
    let out = Command::new(WORKBENCH)
        .args(args)
        .output()
        .context("running the workbench")?;
    ensure!(
        out.status.success(),
        "`workbench {}` failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    Ok(())
}

fn runs(dir: &Path) -> Result<Vec<Value>> {
    let results: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("results.json"))?)?;
    Ok(results["runs"].as_array().context("runs")?.clone())
}

/// The error figures of a run that must not depend on how the sweep was split.
fn errors(run: &Value) -> Vec<f64> {
    let error = &run["error"];
    [
        &error["mae_shadowed"],
        &error["mae_all"],
        &error["vs_exact"]["mae_shadowed"],
        &error["vs_exact"]["max_abs"],
        &error["reference_vs_exact"]["mae_shadowed"],
    ]
    .iter()
    .map(|v| v.as_f64().unwrap_or(f64::NAN))
    .collect()
}

#[test]
fn the_slurm_array_of_cluster_md_gives_the_errors_of_the_whole_sweep() -> Result<()> {
    let slurm = LocalSlurm::start()?;
    let work = tempfile::tempdir()?;
    let sweep = work.path().join("sweep.toml");
    std::fs::write(&sweep, SWEEP)?;
    let sharded = work.path().join("sharded");
    let script = repository().join("sweeps/overview-slurm.sh");
    let export = format!(
        "ALL,SWEEP={},OUT={},WORKBENCH={WORKBENCH}",
        sweep.display(),
        sharded.display()
    );
    std::fs::create_dir_all(&sharded)?;
    let log = format!("--output={}/slurm-%A_%a.log", sharded.display());
    output(
        "sbatch",
        &[
            "--wait",
            "--array=0-2",
            &format!("--export={export}"),
            &log,
            script.to_str().context("path")?,
        ],
        &slurm.conf,
    )
    .context("the array job failed: its logs are in the shard folder")?;
    merged_shards_equal_the_whole_sweep(work.path(), &sweep, &sharded, 3)
}

/// The CLUSTER.md command for one machine, as a file: two shards at once with GNU parallel.
#[test]
fn the_gnu_parallel_shards_give_the_errors_of_the_whole_sweep() -> Result<()> {
    ensure!(
        found("parallel"),
        "GNU parallel not found: install it with `apt-get install -y parallel` (.ci/run does)"
    );
    let work = tempfile::tempdir()?;
    let sweep = work.path().join("sweep.toml");
    std::fs::write(&sweep, SWEEP)?;
    let sharded = work.path().join("sharded");
    let out = Command::new(repository().join("sweeps/overview-parallel.sh"))
        .env("SWEEP", &sweep)
        .env("OUT", &sharded)
        .env("WORKBENCH", WORKBENCH)
        .env("SHARDS", "2")
        .env("JOBS", "2")
        .output()
        .context("running sweeps/overview-parallel.sh")?;
    ensure!(
        out.status.success(),
        "sweeps/overview-parallel.sh failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    merged_shards_equal_the_whole_sweep(work.path(), &sweep, &sharded, 2)
}

/// Merges `count` shard folders under `sharded` and checks every run's errors against the same
/// sweep run in one piece (1e-6).
fn merged_shards_equal_the_whole_sweep(
    work: &Path,
    sweep: &Path,
    sharded: &Path,
    count: usize,
) -> Result<()> {
    let shards: Vec<PathBuf> = (0..count)
        .map(|i| sharded.join(format!("shard-{i}")))
        .collect();
    for shard in &shards {
        ensure!(
            shard.join("results.json").is_file(),
            "{} has no results.json",
            shard.display()
        );
    }
    let merged = work.join("merged");
    let mut args = vec!["merge".to_string()];
    args.extend(shards.iter().map(|s| s.display().to_string()));
    args.extend(["--out".into(), merged.display().to_string()]);
    workbench(&args.iter().map(String::as_str).collect::<Vec<_>>())?;

    let whole = work.join("whole");
    workbench(&[
        "bench",
        "--sweep",
        sweep.to_str().context("path")?,
        "--out",
        whole.to_str().context("path")?,
    ])?;
    let (merged, whole) = (runs(&merged)?, runs(&whole)?);
    ensure!(
        merged.len() == 6 && whole.len() == 6,
        "{} merged runs, {} whole",
        merged.len(),
        whole.len()
    );
    for (a, b) in merged.iter().zip(&whole) {
        ensure!(a["index"] == b["index"] && a["technique"] == b["technique"]);
        let (ea, eb) = (errors(a), errors(b));
        for (x, y) in ea.iter().zip(&eb) {
            ensure!(
                x.is_finite() && (x - y).abs() <= 1e-6,
                "run {}: sharded {ea:?}, whole {eb:?}",
                a["index"]
            );
        }
    }
    Ok(())
}

/// The Kubernetes Indexed Job cannot run here; what it must say can be checked: an indexed
/// `batch/v1` Job whose shard count matches its completions and whose pods run the same sweep
/// command as the Slurm array, one shard per completion index.
#[test]
fn the_kubernetes_job_is_an_indexed_job_over_every_shard() -> Result<()> {
    let text = std::fs::read_to_string(repository().join("sweeps/overview-k8s.yaml"))?;
    let job: Value = serde_yaml::from_str(&text).context("sweeps/overview-k8s.yaml is YAML")?;
    ensure!(
        job["apiVersion"] == "batch/v1" && job["kind"] == "Job",
        "{job}"
    );
    let spec = &job["spec"];
    ensure!(spec["completionMode"] == "Indexed", "not an indexed job");
    let completions = spec["completions"].as_u64().context("completions")?;
    let container = &spec["template"]["spec"]["containers"][0];
    let shards = container["env"]
        .as_array()
        .and_then(|env| env.iter().find(|e| e["name"] == "SHARDS"))
        .and_then(|e| e["value"].as_str())
        .context("SHARDS")?
        .parse::<u64>()?;
    ensure!(
        shards == completions,
        "{completions} completions for {shards} shards"
    );
    let command = container["args"][0].as_str().context("args")?;
    for part in [
        "workbench bench --sweep sweeps/overview.toml",
        "--shard \"${JOB_COMPLETION_INDEX}/${SHARDS}\"",
        "shard-${JOB_COMPLETION_INDEX}",
    ] {
        ensure!(
            command.contains(part),
            "the pod command lacks `{part}`: {command}"
        );
    }
    let volume = &spec["template"]["spec"]["volumes"][0];
    ensure!(
        volume["persistentVolumeClaim"]["claimName"].is_string(),
        "the shards need a shared volume"
    );
    ensure!(
        spec["template"]["spec"]["restartPolicy"] == "Never",
        "a failed shard must fail, not loop"
    );
    Ok(())
}
