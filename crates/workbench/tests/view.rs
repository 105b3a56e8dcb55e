//! `workbench view` in a real window: the smoke test that CI runs under Xvfb. With `DISPLAY`
//! unset the test starts its own Xvfb (and fails, saying what to install, when there is none).

use std::{
    io::{BufRead, BufReader},
    process::{Child, Command, Stdio},
};

use anyhow::{bail, ensure, Context, Result};

/// An X server for the test: the session's own display, or a private Xvfb stopped on drop.
struct Display {
    name: String,
    xvfb: Option<Child>,
}

impl Display {
    fn get() -> Result<Self> {
        if let Ok(name) = std::env::var("DISPLAY") {
            if !name.is_empty() {
                return Ok(Self { name, xvfb: None });
            }
        }
        // `-displayfd 1`: Xvfb picks a free display number and prints it on stdout once ready.
        let mut xvfb = match Command::new("Xvfb")
            .args([
                "-displayfd",
                "1",
                "-screen",
                "0",
                "1024x768x24",
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
        {
            Ok(child) => child,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
                "DISPLAY is unset and Xvfb is not installed: `apt-get install xvfb` \
                 (the viewer smoke test needs an X server)"
            ),
            Err(e) => return Err(e).context("cannot start Xvfb"),
        };
        let mut line = String::new();
        BufReader::new(xvfb.stdout.take().context("Xvfb stdout")?)
            .read_line(&mut line)
            .context("reading the display number from Xvfb")?;
        let number: u32 = match line.trim().parse() {
            Ok(n) => n,
            Err(_) => {
                let _ = xvfb.kill();
                bail!("Xvfb did not report a display number (got {line:?})");
            }
        };
        Ok(Self {
            name: format!(":{number}"),
            xvfb: Some(xvfb),
        })
    }
}

impl Drop for Display {
    fn drop(&mut self) {
        if let Some(xvfb) = self.xvfb.as_mut() {
            let _ = xvfb.kill();
            let _ = xvfb.wait();
        }
    }
}

#[test]
fn view_renders_frames_in_a_window_and_saves_a_screenshot() -> Result<()> {
    let display = Display::get()?;
    let dir = tempfile::tempdir()?;
    let shot = dir.path().join("view.png");
    let output = Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args([
            "view",
            "--scene",
            "atty-square",
            "--technique",
            "pcss",
            "--size",
            "640x360",
            "--frames",
            "4",
            "--screenshot",
        ])
        .arg(&shot)
        .env("DISPLAY", &display.name)
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .context("the workbench binary runs")?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    ensure!(
        output.status.success(),
        "workbench view failed on {}:\n{stdout}\n{stderr}",
        display.name
    );
    ensure!(stdout.contains("4 frames at 640x360"), "{stdout}");
    let image = image::open(&shot)
        .with_context(|| format!("the screenshot {} is a PNG", shot.display()))?
        .to_rgb8();
    ensure!(image.dimensions() == (640, 360), "{:?}", image.dimensions());
    // UI text and a shaded scene: many distinct colours, not a blank or single-colour frame.
    let mut colours: Vec<[u8; 3]> = image.pixels().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    ensure!(
        colours.len() > 50,
        "only {} colours in the screenshot",
        colours.len()
    );
    Ok(())
}

#[test]
fn view_rejects_bad_input_before_opening_a_window() -> Result<()> {
    for args in [
        &["view", "--technique", "no-such-technique", "--frames", "1"][..],
        &["view", "--size", "0x10", "--frames", "1"],
        &["view", "--param", "filter_samples=100000", "--frames", "1"],
        &["view", "--screenshot", "x.png"],
    ] {
        let output = Command::new(env!("CARGO_BIN_EXE_workbench"))
            .args(args)
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()?;
        let stderr = String::from_utf8_lossy(&output.stderr);
        ensure!(
            output.status.code() == Some(2),
            "{args:?}: exit {:?}\n{stderr}",
            output.status.code()
        );
        ensure!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
    Ok(())
}
