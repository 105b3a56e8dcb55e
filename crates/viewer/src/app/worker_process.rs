//! The technique's render worker in a child process (docs/ARCHITECTURE.md, "The viewer's render
//! worker"): a frame that never ends (a WGSL file whose `visibility` loops) cannot be stopped
//! inside a process, and on lavapipe it also stalls the UI's own submissions (measured: the
//! window froze in `vkQueueSubmit` while the worker's device ran the shader). Killing the child
//! stops it at once, and the next technique starts in a fresh one.
//!
//! The child is the viewer's host program run again ([`WorkerCommand`]; `workbench view-worker`),
//! which calls [`serve`] with the same registry. The two talk over the child's stdin and stdout
//! in framed bincode messages ([`write_message`], [`read_message`]): the parent sends the
//! technique to make ([`Start`]), then the scene once per scene and one [`FrameRequest`] at a
//! time; the child answers whether the technique was made, then one [`FrameDone`] per request,
//! the same the worker thread sends. Its stderr is kept (last lines) to say why it ended.

use std::{
    collections::VecDeque,
    ffi::OsString,
    io::{BufRead, Read, Write},
    path::PathBuf,
    process::{Child, ChildStdin, ChildStdout, Command, ExitCode, Stdio},
    sync::{mpsc, Arc, Mutex},
    thread,
    time::{Duration, Instant},
};

use serde::{de::DeserializeOwned, Deserialize, Serialize};
use softshadow_bench::fault::Faults;
use softshadow_core::{BuildControl, Gpu, ParamValue, Registry, Scene};

use super::render_worker::{
    intern_unit, FrameDone, FrameRequest, RenderWorker, StartError, Started, Worker,
};

/// The program the viewer runs each technique's render worker in, with its arguments and extra
/// environment variables: a program that calls [`crate::serve_render_worker`] with the viewer's
/// registry (`workbench view-worker`).
#[derive(Clone, Debug, Default)]
pub struct WorkerCommand {
    pub program: OsString,
    pub args: Vec<OsString>,
    pub env: Vec<(OsString, OsString)>,
}

/// The technique a worker process makes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(super) enum TechniqueSource {
    /// A technique of the registry, by id (the child's registry is the viewer's).
    Registered(String),
    /// A WGSL file technique (docs/WGSL.md), loaded by the child from its path.
    File(PathBuf),
}

/// What the parent sends first.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(super) struct Start {
    pub(super) technique: TechniqueSource,
    #[serde(with = "super::render_worker::wire_params")]
    pub(super) params: Vec<(String, ParamValue)>,
    /// The worker's number in the viewer's session (from 0): what `SOFTSHADOW_FAULT`'s `K`
    /// counts in the viewer.
    pub(super) index: usize,
    /// The faults to inject (`SOFTSHADOW_FAULT`'s text; empty: none).
    pub(super) faults: String,
}

/// A message to the child.
#[derive(Serialize, Deserialize)]
enum ToWorker {
    Start(Start),
    /// A scene, with its hash, before the first frame that needs it.
    Scene(u64, Scene),
    /// A frame, and whether the UI has cancelled the precompute.
    Frame(FrameRequest, bool),
}

/// A message from the child.
#[derive(Serialize, Deserialize)]
enum FromWorker {
    Started(Result<(), StartError>),
    Frame(Box<FrameDone>),
}

/// What starts a framed message on a pipe: a line that a library printing to stdout cannot
/// mistake (`running 1 test` from a test harness is skipped, for one).
const FRAME_TAG: &str = "softshadow-worker-message";

/// How every message [`serve`] writes to stderr begins.
const OWN_MESSAGE: &str = "the render worker";

/// Lines of the child's stderr kept to explain how it ended.
const STDERR_LINES: usize = 40;

/// Writes `message` as one framed message: a tag line with its length, then its bincode bytes.
fn write_message<T: Serialize>(out: &mut impl Write, message: &T) -> std::io::Result<()> {
    let bytes = bincode::serialize(message).map_err(std::io::Error::other)?;
    writeln!(out, "{FRAME_TAG} {}", bytes.len())?;
    out.write_all(&bytes)?;
    out.flush()
}

/// Reads the next framed message; `None` at the end of the stream. Lines before it that are not
/// a tag are logged and skipped.
fn read_message<T: DeserializeOwned>(input: &mut impl BufRead) -> std::io::Result<Option<T>> {
    let mut line = Vec::new();
    loop {
        line.clear();
        if input.read_until(b'\n', &mut line)? == 0 {
            return Ok(None);
        }
        let text = String::from_utf8_lossy(&line);
        // The tag may follow what something printed without a newline (a test harness's
        // `test name ... `).
        let Some(at) = text.find(FRAME_TAG) else {
            log::debug!("render worker pipe: {}", text.trim_end());
            continue;
        };
        let length = &text[at + FRAME_TAG.len()..];
        let length: usize = length.trim().parse().map_err(std::io::Error::other)?;
        let mut bytes = vec![0; length];
        input.read_exact(&mut bytes)?;
        return bincode::deserialize(&bytes)
            .map(Some)
            .map_err(std::io::Error::other);
    }
}

/// The parent's hold on a worker process: the child (killed when retired) and its last words.
pub(super) struct ProcessLink {
    child: Child,
    stderr: Arc<Mutex<VecDeque<String>>>,
}

impl ProcessLink {
    /// Kills the child and reaps it (`SIGKILL` ends it whatever its threads are doing).
    pub(super) fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// How the child ended, with the last line it wrote to stderr.
    pub(super) fn why_ended(&mut self) -> String {
        // Its stdout closes a moment before it exits.
        let deadline = Instant::now() + Duration::from_secs(2);
        let status = loop {
            match self.child.try_wait() {
                Ok(Some(status)) => break Some(status),
                Ok(None) if Instant::now() < deadline => thread::sleep(Duration::from_millis(10)),
                _ => break None,
            }
        };
        let how = match status {
            Some(status) => format!("its process ended ({status})"),
            None => "its process stopped answering".into(),
        };
        let tail: Vec<String> = self
            .stderr
            .lock()
            .map(|tail| tail.iter().cloned().collect())
            .unwrap_or_default();
        // The worker's own last message (each starts with `the render worker`) says it best;
        // else a panic's message, else the last line.
        let own = tail
            .iter()
            .rev()
            .find(|line| line.starts_with(OWN_MESSAGE))
            .cloned();
        match own.or_else(|| softshadow_bench::isolate::last_words(&tail)) {
            Some(line) => format!("{how}; its last words: {line}"),
            None => how,
        }
    }
}

impl Drop for ProcessLink {
    fn drop(&mut self) {
        self.kill();
    }
}

impl RenderWorker {
    /// A worker for `start`'s technique in a new child process run by `command`. Returns at
    /// once, as [`RenderWorker::spawn`]: the technique's creation (or its error) comes back
    /// through [`RenderWorker::poll_started`]. `build` gets the child's precompute progress
    /// and sends its cancel flag with every request.
    pub(super) fn in_process(
        command: &WorkerCommand,
        start: Start,
        build: BuildControl,
    ) -> Result<Self, StartError> {
        let mut child = spawn(command).map_err(|e| {
            StartError::Device(format!(
                "cannot start the render worker's process `{}`: {e}",
                command.program.to_string_lossy()
            ))
        })?;
        let (stdin, stdout, stderr) = match (child.stdin.take(), child.stdout.take()) {
            (Some(stdin), Some(stdout)) => (stdin, stdout, child.stderr.take()),
            _ => return Err(StartError::Device("the worker process has no pipes".into())),
        };
        let (request_tx, request_rx) = mpsc::channel::<FrameRequest>();
        let (frame_tx, frame_rx) = mpsc::channel::<FrameDone>();
        let (started_tx, started_rx) = mpsc::channel::<Started>();
        let control = build.clone();
        thread::Builder::new()
            .name("render worker: writer".into())
            .spawn(move || send_requests(stdin, start, &request_rx, &control))
            .map_err(|e| StartError::Device(format!("cannot start its writer thread: {e}")))?;
        thread::Builder::new()
            .name("render worker: reader".into())
            .spawn(move || receive_frames(stdout, &started_tx, &frame_tx, &build))
            .map_err(|e| StartError::Device(format!("cannot start its reader thread: {e}")))?;
        let tail = Arc::new(Mutex::new(VecDeque::new()));
        keep_tail(stderr, tail.clone());
        let mut worker = RenderWorker::from_channels(request_tx, started_rx, frame_rx);
        worker.set_process(ProcessLink {
            child,
            stderr: tail,
        });
        Ok(worker)
    }
}

fn spawn(command: &WorkerCommand) -> std::io::Result<Child> {
    let mut process = Command::new(&command.program);
    process
        .args(&command.args)
        .envs(command.env.iter().map(|(k, v)| (k, v)))
        .env(
            softshadow_bench::isolate::PARENT_ENV,
            std::process::id().to_string(),
        )
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    #[cfg(unix)]
    {
        // Its own process group: Ctrl-C in the terminal reaches the viewer only, whose end
        // then ends the child (`die_with_parent`).
        std::os::unix::process::CommandExt::process_group(&mut process, 0);
    }
    process.spawn()
}

/// The writer thread: the start, then every request, the scene before the first frame of it.
/// Ends when the UI drops the worker or the child's stdin closes.
fn send_requests(
    stdin: ChildStdin,
    start: Start,
    requests: &mpsc::Receiver<FrameRequest>,
    build: &BuildControl,
) {
    let mut out = std::io::BufWriter::new(stdin);
    if write_message(&mut out, &ToWorker::Start(start)).is_err() {
        return;
    }
    let mut scene_sent = None;
    while let Ok(request) = requests.recv() {
        if scene_sent != Some(request.scene_hash) {
            let scene = ToWorker::Scene(request.scene_hash, (*request.scene).clone());
            if write_message(&mut out, &scene).is_err() {
                return;
            }
            scene_sent = Some(request.scene_hash);
        }
        let frame = ToWorker::Frame(request, build.is_cancelled());
        if write_message(&mut out, &frame).is_err() {
            return;
        }
    }
}

/// The reader thread: whether the technique was made, then every finished frame, its
/// precompute progress copied into `build`. Ends at the end of the child's stdout.
fn receive_frames(
    stdout: ChildStdout,
    started: &mpsc::Sender<Started>,
    frames: &mpsc::Sender<FrameDone>,
    build: &BuildControl,
) {
    let mut input = std::io::BufReader::new(stdout);
    while let Ok(Some(message)) = read_message::<FromWorker>(&mut input) {
        let sent = match message {
            FromWorker::Started(result) => started.send(result.map(|()| None)).is_ok(),
            FromWorker::Frame(done) => {
                match &done.build {
                    Some((finished, total, unit)) => {
                        build.start(*total, intern_unit(unit));
                        build
                            .done
                            .store(*finished, std::sync::atomic::Ordering::Relaxed);
                    }
                    None => build.finish(),
                }
                frames.send(*done).is_ok()
            }
        };
        if !sent {
            return;
        }
    }
}

/// Keeps the last [`STDERR_LINES`] lines of the child's stderr in `tail`, logging each.
fn keep_tail(stderr: Option<impl Read + Send + 'static>, tail: Arc<Mutex<VecDeque<String>>>) {
    let Some(stderr) = stderr else { return };
    let _ = thread::Builder::new()
        .name("render worker: stderr".into())
        .spawn(move || {
            for line in std::io::BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                log::info!("render worker: {line}");
                if let Ok(mut tail) = tail.lock() {
                    if tail.len() == STDERR_LINES {
                        tail.pop_front();
                    }
                    tail.push_back(line);
                }
            }
        });
}

/// In the child: serves one technique's frames over stdin and stdout until the viewer closes
/// the pipe or kills it (see [`crate::serve_render_worker`]).
pub fn serve(registry: &Registry) -> ExitCode {
    softshadow_bench::isolate::die_with_parent();
    match serve_frames(registry) {
        Ok(()) => ExitCode::SUCCESS,
        Err(why) => {
            // The viewer shows this line as the worker's last words.
            eprintln!("{why}");
            ExitCode::FAILURE
        }
    }
}

/// Makes the technique the viewer asks for and answers its frames; `Err`: why the worker
/// stopped, a sentence beginning with [`OWN_MESSAGE`].
fn serve_frames(registry: &Registry) -> Result<(), String> {
    let mut input = std::io::stdin().lock();
    let mut output = std::io::stdout().lock();
    let start = match read_message::<ToWorker>(&mut input) {
        Ok(Some(ToWorker::Start(start))) => start,
        Ok(_) => return Err(
            "the render worker was sent no technique to start: the viewer starts it, not a user"
                .into(),
        ),
        Err(e) => return Err(format!("the render worker cannot read its start: {e}")),
    };
    let faults: Faults = start
        .faults
        .parse()
        .map_err(|e| format!("the render worker cannot inject its faults: {e}"))?;
    let control = BuildControl::default();
    let made = make_worker(registry, &start, &control);
    let reply = FromWorker::Started(made.as_ref().map(|_| ()).map_err(StartError::clone));
    write_message(&mut output, &reply)
        .map_err(|e| format!("the render worker cannot answer the viewer: {e}"))?;
    let mut worker = made.map_err(|e| format!("the render worker could not start: {e}"))?;
    let mut scene: Option<(u64, Arc<Scene>)> = None;
    let mut first_frame = true;
    loop {
        let read = read_message::<ToWorker>(&mut input)
            .map_err(|e| format!("the render worker cannot read its next request: {e}"))?;
        let (mut request, cancelled) = match read {
            Some(ToWorker::Scene(hash, new)) => {
                scene = Some((hash, Arc::new(new)));
                continue;
            }
            Some(ToWorker::Frame(request, cancelled)) => (request, cancelled),
            Some(ToWorker::Start(_)) => {
                return Err("the render worker was sent a second technique".into())
            }
            // The viewer closed the pipe: it is done with this worker.
            None => return Ok(()),
        };
        request.scene = match &scene {
            Some((hash, scene)) if *hash == request.scene_hash => scene.clone(),
            _ => {
                return Err(
                    "the render worker was asked for a frame of a scene it was not sent".into(),
                )
            }
        };
        if std::mem::take(&mut first_frame) {
            inject_faults(&faults, start.index, worker.gpu())?;
        }
        let done = answer(&mut worker, &request, &control, cancelled)?;
        let lost = done.device_lost.clone();
        write_message(&mut output, &FromWorker::Frame(Box::new(done)))
            .map_err(|e| format!("the render worker cannot answer the viewer: {e}"))?;
        if let Some(why) = lost {
            // A lost device is of no further use: the viewer starts a new worker.
            return Err(format!("the render worker's device was lost: {why}"));
        }
    }
}

/// The faults of worker `index`, before its first frame: at the first frame, not at the
/// start, because the viewer waits for its first technique to start, and a `hang` there would
/// hold the window before Cancel is shown. `lost` destroys the device, which the frame then
/// meets.
fn inject_faults(faults: &Faults, index: usize, gpu: &Gpu) -> Result<(), String> {
    faults
        .at_start(index, gpu)
        .map_err(|e| format!("the render worker's first frame failed: {e}"))?;
    faults.in_the_middle(index, gpu);
    Ok(())
}

/// Renders `request` with the precompute's cancel flag as the viewer has it (`cancelled`), and
/// adds the precompute's progress. wgpu panics on some calls to a lost device (a buffer mapped
/// at creation): the loss is then the error.
fn answer(
    worker: &mut Worker,
    request: &FrameRequest,
    control: &BuildControl,
    cancelled: bool,
) -> Result<FrameDone, String> {
    if cancelled {
        control.cancel();
    } else {
        control.clear_cancel();
    }
    let answered =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| worker.answer(request)));
    let mut done = answered.map_err(|_| match worker.gpu().lost() {
        Some(why) => format!("the render worker's device was lost: {why}"),
        None => "the render worker panicked (above: where and why)".to_string(),
    })?;
    done.build = control
        .progress_with_unit()
        .map(|p| (p.done, p.total, p.unit.into_owned()));
    Ok(done)
}

/// The worker for `start`: a device of its own (the adapter chosen as `Gpu::new_headless`
/// does: `WGPU_BACKEND`, `WGPU_ADAPTER_NAME`) and the technique made on it.
fn make_worker(
    registry: &Registry,
    start: &Start,
    control: &BuildControl,
) -> Result<Worker, StartError> {
    let gpu = Gpu::new_headless_with(crate::MEMORY_HINTS)
        .map_err(|e| StartError::Device(e.to_string()))?;
    let info = match &start.technique {
        TechniqueSource::Registered(id) => registry
            .find(id)
            .cloned()
            .map_err(|e| StartError::Technique(e.to_string()))?,
        TechniqueSource::File(path) => {
            softshadow_wgsl::load(path).map_err(|e| StartError::Technique(e.to_string()))?
        }
    };
    // Before the technique: what it holds is counted from here.
    let _ = gpu.wait_idle();
    let baseline = gpu.memory_in_use();
    let mut technique = info
        .create_with(&gpu, &start.params)
        .map_err(|e| StartError::Technique(e.to_string()))?;
    technique.set_build_control(control.clone());
    technique.set_background_build(true);
    Ok(Worker::new(gpu, technique, baseline))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framed_messages_come_back_whole_after_stray_lines() {
        let mut pipe = b"running 1 test\ntest render_worker_child ... ".to_vec();
        write_message(&mut pipe, &(7u64, vec![1.5f32, -2.0], "x".to_string())).unwrap();
        pipe.extend_from_slice(b"a library's line\n");
        write_message(&mut pipe, &42u32).unwrap();
        let mut input = std::io::Cursor::new(pipe);
        let first: (u64, Vec<f32>, String) = read_message(&mut input).unwrap().unwrap();
        assert_eq!(first, (7, vec![1.5, -2.0], "x".into()));
        assert_eq!(read_message::<u32>(&mut input).unwrap(), Some(42));
        assert_eq!(read_message::<u32>(&mut input).unwrap(), None);
    }
}
