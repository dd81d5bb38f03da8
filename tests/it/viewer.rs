//! `irt view` as a user meets it: a real window under Xvfb (started by each test on a free
//! display), real input from xdotool, screenshots compared with the library's headless render.
//! Needs Xvfb and xdotool (scripts/setup.sh installs both); tests run one at a time (one X
//! server and one viewer each, on a 2-core machine) and every wait has a deadline; children are
//! killed when a test ends, however it ends.

use crate::common;

use irt::render::{Mode, Session, Settings};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// One test at a time: each has its own X server and a viewer using both cores.
static SERIAL: Mutex<()> = Mutex::new(());

pub(crate) fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|p| p.into_inner())
}

/// A directory removed when dropped.
pub(crate) struct TempDir(PathBuf);

impl TempDir {
    pub(crate) fn new(name: &str) -> TempDir {
        let dir =
            PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("viewer-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
    pub(crate) fn join(&self, p: &str) -> PathBuf {
        self.0.join(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A child process killed (and reaped) when dropped.
struct Kid(Child);

impl Drop for Kid {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// An Xvfb server on a display of its own (Xvfb picks a free one and reports it when ready),
/// and an XDG_RUNTIME_DIR (mode 0700) for its clients. Stopped with SIGTERM so that it removes its
/// lock file and socket.
pub(crate) struct Xvfb {
    server: Option<Child>,
    display: String,
    runtime: TempDir,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let Some(mut server) = self.server.take() else { return };
        let _ = Command::new("kill").args(["-TERM", &server.id().to_string()]).status();
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = server.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = server.kill();
        let _ = server.wait();
    }
}

impl Xvfb {
    pub(crate) fn start() -> Xvfb {
        let child = Command::new("Xvfb")
            .args(["-displayfd", "1", "-screen", "0", "1024x768x24", "-nolisten", "tcp"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn();
        let mut server = match child {
            Ok(c) => c,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                panic!("Xvfb is not installed: run scripts/setup.sh (it installs Xvfb and xdotool)")
            }
            Err(e) => panic!("cannot start Xvfb: {e}"),
        };
        let ready = lines(server.stdout.take().unwrap());
        let runtime = TempDir::new("xdg");
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&runtime.0, std::fs::Permissions::from_mode(0o700)).unwrap();
        // Stopped by Drop from here on, whatever happens next.
        let mut x = Xvfb { server: Some(server), display: String::new(), runtime };
        // The display number, written once the server accepts connections.
        let n = ready.recv_timeout(Duration::from_secs(20)).expect("Xvfb reports its display within 20 s");
        let n = n.trim();
        assert!(n.parse::<u32>().is_ok(), "Xvfb reported display `{n}`");
        x.display = format!(":{n}");
        x
    }

    pub(crate) fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("DISPLAY", &self.display)
            .env("XDG_RUNTIME_DIR", &self.runtime.0)
            .env_remove("WAYLAND_DISPLAY")
            .env("IRT_CACHE_DIR", "off");
        c
    }

    /// Runs xdotool with `args`, at most `limit`; its stdout.
    pub(crate) fn xdotool(&self, args: &[&str], limit: Duration) -> String {
        match self.try_xdotool(args, limit) {
            Ok(out) => out,
            Err(status) => panic!("xdotool {args:?} failed: {status}"),
        }
    }

    /// [`Self::xdotool`], its exit status when it fails.
    pub(crate) fn try_xdotool(
        &self,
        args: &[&str],
        limit: Duration,
    ) -> Result<String, std::process::ExitStatus> {
        let mut child = Kid(self
            .command("xdotool")
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("xdotool: {e} (run scripts/setup.sh)")));
        let deadline = Instant::now() + limit;
        loop {
            if let Some(status) = child.0.try_wait().unwrap() {
                let mut out = String::new();
                use std::io::Read;
                child.0.stdout.take().unwrap().read_to_string(&mut out).unwrap();
                return if status.success() { Ok(out) } else { Err(status) };
            }
            assert!(Instant::now() < deadline, "xdotool {args:?} took longer than {limit:?}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// A running `irt view` with its stdout and stderr lines.
struct Viewer {
    kid: Kid,
    stdout: Receiver<String>,
    stderr: Receiver<String>,
    stderr_seen: Vec<String>,
}

fn lines(r: impl std::io::Read + Send + 'static) -> Receiver<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(r).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

impl Viewer {
    fn start(x: &Xvfb, args: &[&str]) -> Viewer {
        let mut child = x
            .command(env!("CARGO_BIN_EXE_irt"))
            .arg("view")
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("irt runs");
        let stdout = lines(child.stdout.take().unwrap());
        let stderr = lines(child.stderr.take().unwrap());
        Viewer { kid: Kid(child), stdout, stderr, stderr_seen: Vec::new() }
    }

    fn pid(&self) -> u32 {
        self.kid.0.id()
    }

    fn drain_stderr(&mut self) {
        while let Ok(l) = self.stderr.try_recv() {
            self.stderr_seen.push(l);
        }
    }

    fn alive(&mut self) -> bool {
        self.kid.0.try_wait().unwrap().is_none()
    }

    /// Waits for the exit (at most `limit`) and asserts it was a clean exit 0.
    fn exits_cleanly(&mut self, limit: Duration) {
        let deadline = Instant::now() + limit;
        let status = loop {
            if let Some(s) = self.kid.0.try_wait().unwrap() {
                break s;
            }
            assert!(Instant::now() < deadline, "irt view did not exit within {limit:?}");
            std::thread::sleep(Duration::from_millis(50));
        };
        std::thread::sleep(Duration::from_millis(100));
        self.drain_stderr();
        let err = self.stderr_seen.join("\n");
        assert!(status.success(), "irt view exited with {status}; stderr:\n{err}");
        assert!(!err.contains("panicked"), "irt view panicked:\n{err}");
        assert!(!err.contains("XDG_RUNTIME_DIR"), "the Wayland probe's message leaked:\n{err}");
    }

    /// The next stdout line starting with `prefix`, within `limit`.
    fn line_starting(&mut self, prefix: &str, limit: Duration) -> String {
        let deadline = Instant::now() + limit;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.stdout.recv_timeout(left) {
                Ok(l) if l.starts_with(prefix) => return l,
                Ok(_) => {}
                Err(_) => {
                    self.drain_stderr();
                    panic!("no `{prefix}` line within {limit:?}; stderr:\n{}", self.stderr_seen.join("\n"));
                }
            }
        }
    }
}

/// The window of the viewer, once it is mapped.
/// `irt view` of the default scene at 256×192, conventional, one sample, no HUD, screenshots to
/// `shot` (and `extra`), its window focused for xdotool's input; with the window's id.
fn focused_viewer(x: &Xvfb, shot: &Path, extra: &[&str]) -> (Viewer, String) {
    let mut args = vec![
        "--size",
        "256x192",
        "--mode",
        "conventional",
        "--max-samples",
        "1",
        "--no-hud",
        "--screenshot",
        shot.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let v = Viewer::start(x, &args);
    let wid = window_id(x);
    focus(x, &wid);
    (v, wid)
}

/// Gives window `wid` the keyboard focus. A window just found visible can still refuse it
/// (XSetInputFocus fails until the window manager-less server has it viewable; seen under the
/// load of the MPI tests running beside): a few tries, then the failure.
pub(crate) fn focus(x: &Xvfb, wid: &str) {
    for _ in 0..10 {
        if x.try_xdotool(&["windowfocus", "--sync", wid], Duration::from_secs(10)).is_ok() {
            return;
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    x.xdotool(&["windowfocus", "--sync", wid], Duration::from_secs(10));
}

pub(crate) fn window_id(x: &Xvfb) -> String {
    let out = x.xdotool(&["search", "--sync", "--onlyvisible", "--name", "^irt"], Duration::from_secs(60));
    out.lines().next().expect("a window id").trim().to_string()
}

pub(crate) fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8();
    (img.width(), img.height(), img.into_raw())
}

/// `irt render` of the default scene at `size` into `out`: its RGB bytes.
fn irt_render(out: &Path, size: &str) -> Vec<u8> {
    let status = Command::new(env!("CARGO_BIN_EXE_irt"))
        .args(["render", "--size", size, "--out", out.to_str().unwrap()])
        .env("IRT_CACHE_DIR", "off")
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    decode(out).2
}

/// The default scene at `w`×`h`, traced headless by the library for `passes` pictures.
pub(crate) fn headless(settings: Settings, w: u32, h: u32, passes: u32) -> Vec<u8> {
    let ctx = common::gpu();
    let mut scene = irt::scene::default_scene();
    scene.camera.width = w;
    scene.camera.height = h;
    let mut s = Session::new(&ctx, &scene, settings).unwrap();
    for _ in 0..passes {
        s.complete_pass(&ctx);
    }
    s.read_image(&ctx).to_srgb8()
}

/// The window `wid` as the X server holds it (ImageMagick's `import`), RGB.
pub(crate) fn capture(x: &Xvfb, wid: &str, path: &Path) -> Vec<u8> {
    let status = x
        .command("import")
        .args(["-window", wid, path.to_str().unwrap()])
        .status()
        .expect("ImageMagick's import runs (scripts/setup.sh installs it)");
    assert!(status.success(), "import -window {wid}: {status}");
    decode(path).2
}

/// The window's size, as X reports it (`xdotool getwindowgeometry`).
fn window_geometry(x: &Xvfb, wid: &str) -> [u32; 2] {
    let out = x.xdotool(&["getwindowgeometry", wid], Duration::from_secs(10));
    let g = out.lines().find_map(|l| l.trim().strip_prefix("Geometry: ")).expect("a geometry line");
    let (w, h) = g.split_once('x').expect("WxH");
    [w.trim().parse().unwrap(), h.trim().parse().unwrap()]
}

pub(crate) fn differing_pixels(a: &[u8], b: &[u8]) -> usize {
    a.chunks(3).zip(b.chunks(3)).filter(|(p, q)| p != q).count()
}

/// (a) `--frames 3 --screenshot`: exit 0 and the PNG equals the library's headless render of the
/// same camera bit for bit (same shaders, same device, same sample sequence: tolerance zero).
/// Conventional: 3 pictures are 3 whole frames (3 refinement samples). Frameless with one sample:
/// once the pass is done the picture is the pass, however many slices each present took; and
/// that one-sample picture is also what `irt render` writes.
#[test]
fn scripted_screenshot_matches_headless_render() {
    let _serial = serial();
    let x = Xvfb::start();
    let dir = TempDir::new("a");
    let (w, h) = (256, 192);
    let cases: [(&[&str], Settings, u32); 2] = [
        (&["--mode", "conventional"], Settings { mode: Mode::conventional(), ..Settings::default() }, 3),
        (
            &["--mode", "frameless", "--max-samples", "1", "--frames", "12"],
            Settings { mode: Mode::frameless(), max_samples: 1, ..Settings::default() },
            1,
        ),
    ];
    for (extra, settings, passes) in cases {
        let shot = dir.join("a.png");
        let _ = std::fs::remove_file(&shot);
        let shot_arg = shot.to_str().unwrap();
        let mut args = vec!["--size", "256x192", "--screenshot", shot_arg];
        args.extend_from_slice(extra);
        if !extra.contains(&"--frames") {
            args.extend_from_slice(&["--frames", "3"]);
        }
        let t = Instant::now();
        let mut v = Viewer::start(&x, &args);
        v.exits_cleanly(Duration::from_secs(120));
        eprintln!("{extra:?}: {:.1} s", t.elapsed().as_secs_f64());
        let (sw, sh, got) = decode(&shot);
        assert_eq!((sw, sh), (w, h));
        let want = headless(settings, w, h, passes);
        let diff = differing_pixels(&got, &want);
        assert_eq!(diff, 0, "{extra:?}: {diff} of {} pixels differ from the headless render", w * h);
        if passes == 1 {
            // One sample: also what `irt render` writes at that size.
            let rendered = irt_render(&dir.join("render.png"), "256x192");
            assert_eq!(differing_pixels(&got, &rendered), 0, "{extra:?}: differs from `irt render`");
        }
        // Not a black or blank picture.
        assert!(got.chunks(3).filter(|p| p.iter().any(|&c| c > 20)).count() > (w * h / 2) as usize);
    }
}

/// Presses P until two screenshots a second apart are the same (the picture has converged with
/// --max-samples 1), within `limit`; the picture.
fn settled_screenshot(x: &Xvfb, v: &mut Viewer, shot: &Path, limit: Duration) -> Vec<u8> {
    let deadline = Instant::now() + limit;
    let mut last: Option<Vec<u8>> = None;
    loop {
        x.xdotool(&["key", "p"], Duration::from_secs(10));
        v.line_starting("screenshot:", Duration::from_secs(30));
        let (_, _, img) = decode(shot);
        let blank = img.chunks(3).all(|p| p == [0, 0, 0]);
        if !blank && last.as_ref() == Some(&img) {
            return img;
        }
        last = Some(img);
        assert!(Instant::now() < deadline, "the picture did not settle within {limit:?}");
        std::thread::sleep(Duration::from_millis(1000));
    }
}

/// (b) Real input moves the camera: a left drag and a `w` change the picture; Escape exits 0.
#[test]
fn mouse_drag_and_keys_change_the_picture_and_escape_exits() {
    let _serial = serial();
    let x = Xvfb::start();
    let dir = TempDir::new("b");
    let shot = dir.join("b.png");
    let (mut v, wid) = focused_viewer(&x, &shot, &[]);
    let before = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(60));
    x.xdotool(&["mousemove", "--window", &wid, "128", "96"], Duration::from_secs(10));
    x.xdotool(&["mousedown", "1"], Duration::from_secs(10));
    for dx in [10, 20, 30, 40, 60] {
        x.xdotool(&["mousemove", "--window", &wid, &(128 + dx).to_string(), "100"], Duration::from_secs(10));
        std::thread::sleep(Duration::from_millis(30));
    }
    x.xdotool(&["mouseup", "1"], Duration::from_secs(10));
    x.xdotool(&["key", "w"], Duration::from_secs(10));
    let after = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(60));
    let diff = differing_pixels(&before, &after);
    assert!(diff > before.len() / 3 / 20, "only {diff} pixels changed after the drag and `w`");
    assert!(v.alive());
    x.xdotool(&["key", "Escape"], Duration::from_secs(10));
    v.exits_cleanly(Duration::from_secs(20));
}

/// (b2) The keys as the README lists them: holding `q` flies down — the picture changes and the
/// viewer keeps running (`q` used to quit) — and `Esc` quits with status 0.
#[test]
fn holding_q_flies_down_and_escape_quits() {
    let _serial = serial();
    let x = Xvfb::start();
    let dir = TempDir::new("q");
    let shot = dir.join("q.png");
    let (mut v, _wid) = focused_viewer(&x, &shot, &[]);
    let before = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(60));
    x.xdotool(&["keydown", "q"], Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(400));
    x.xdotool(&["keyup", "q"], Duration::from_secs(10));
    assert!(v.alive(), "`q` quit the viewer");
    let after = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(60));
    let diff = differing_pixels(&before, &after);
    assert!(diff > before.len() / 3 / 20, "only {diff} pixels changed while `q` was held");
    assert!(v.alive());
    x.xdotool(&["key", "Escape"], Duration::from_secs(10));
    v.exits_cleanly(Duration::from_secs(20));
}

/// (c) The window resized to 1×1 and back neither crashes nor hangs, the render follows the
/// window's size, and Escape still exits 0.
#[test]
fn resize_to_one_pixel_and_back_survives() {
    let _serial = serial();
    let x = Xvfb::start();
    let dir = TempDir::new("c");
    let shot = dir.join("c.png");
    let mut v = Viewer::start(&x, &["--size", "256x192", "--screenshot", shot.to_str().unwrap()]);
    let wid = window_id(&x);
    for (w, h) in [(1, 1), (256, 192), (1, 1), (300, 200)] {
        x.xdotool(&["windowsize", &wid, &w.to_string(), &h.to_string()], Duration::from_secs(10));
        std::thread::sleep(Duration::from_millis(1500));
        let geometry = x.xdotool(&["getwindowgeometry", &wid], Duration::from_secs(10));
        assert!(geometry.contains(&format!("Geometry: {w}x{h}")), "not resized to {w}x{h}: {geometry}");
        assert!(v.alive(), "irt view died after the resize to {w}x{h}");
    }
    // The viewer followed: `C` prints the window's size, and the screenshot has it.
    focus(&x, &wid);
    x.xdotool(&["key", "c"], Duration::from_secs(10));
    v.line_starting("width = 300", Duration::from_secs(20));
    v.line_starting("height = 200", Duration::from_secs(5));
    x.xdotool(&["key", "p"], Duration::from_secs(10));
    v.line_starting("screenshot:", Duration::from_secs(30));
    assert_eq!(decode(&shot).0, 300);
    x.xdotool(&["key", "Escape"], Duration::from_secs(10));
    v.exits_cleanly(Duration::from_secs(20));
}

fn rss_kib(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// (d) 1000 pictures at 64×48 (HUD on, refinement never stopping): resident memory at the end is
/// at most 16 MiB above what it was at picture 200 (checked: leaking 64 KiB a picture fails it).
#[test]
fn soak_1000_pictures_keeps_memory_flat() {
    let _serial = serial();
    let x = Xvfb::start();
    let t = Instant::now();
    let mut v = Viewer::start(&x, &["--size", "64x48", "--frames", "1000", "--max-samples", "0"]);
    let pid = v.pid();
    let (mut at200, mut last) = (None, None);
    let deadline = Instant::now() + Duration::from_secs(120);
    while v.alive() {
        assert!(Instant::now() < deadline, "1000 pictures took over 120 s");
        let rss = rss_kib(pid);
        while let Ok(l) = v.stderr.try_recv() {
            if l.contains(" 200/1000 pictures") {
                at200 = rss;
            }
            v.stderr_seen.push(l);
        }
        if rss.is_some() {
            last = rss;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    v.exits_cleanly(Duration::from_secs(5));
    let at200 = at200.unwrap_or_else(|| panic!("no progress line for picture 200: {:?}", v.stderr_seen));
    let last = last.expect("RSS sampled");
    eprintln!(
        "RSS at picture 200: {} MiB, at the end: {} MiB, {:.1} s",
        at200 / 1024,
        last / 1024,
        t.elapsed().as_secs_f64()
    );
    assert!(last <= at200 + 16 * 1024, "RSS grew from {at200} KiB to {last} KiB over 800 pictures");
}

/// The default scene as `irt view --size 256x192` traces it (the camera at the window's size).
fn default_at(w: u32, h: u32) -> irt::scene::Scene {
    let mut scene = irt::scene::default_scene();
    scene.camera.width = w;
    scene.camera.height = h;
    scene
}

/// (e) A click on a sphere selects it (the viewer says which on stdout, and it is the sphere the
/// f64 reference finds under that pixel); K switches its material's kind and the picture
/// changes; T writes a TOML that loads back to the default scene with exactly that edit.
#[test]
fn click_selects_a_sphere_and_the_edited_scene_saves_as_toml() {
    use irt::app::edit::{kind_name, next_kind, Picker, Selection};
    use irt::reference::Primitive;
    let _serial = serial();
    let x = Xvfb::start();
    let dir = TempDir::new("e");
    let shot = dir.join("e.png");
    let saved = dir.join("edited.toml");
    let (w, h) = (256u32, 192u32);
    // A pixel over a sphere, as the reference sees it.
    let scene = default_at(w, h);
    let mut picker = Picker::default();
    let (px, py, sphere) = (0..h)
        .step_by(8)
        .flat_map(|y| (0..w).step_by(8).map(move |x| (x, y)))
        .find_map(|(x, y)| match picker.pick(&scene, [x as f64, y as f64], [w, h]) {
            Some(Selection::Object(Primitive::Sphere(i))) => Some((x, y, i)),
            _ => None,
        })
        .expect("the default scene shows a sphere");
    let m = scene.spheres[sphere].material as usize;
    let (mut v, wid) = focused_viewer(&x, &shot, &["--save", saved.to_str().unwrap()]);
    let before = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(60));
    x.xdotool(&["mousemove", "--window", &wid, &px.to_string(), &py.to_string()], Duration::from_secs(10));
    x.xdotool(&["click", "1"], Duration::from_secs(10));
    let line = v.line_starting("selected:", Duration::from_secs(20));
    assert!(line.starts_with(&format!("selected: sphere {sphere} material {m} ")), "{line}");
    x.xdotool(&["key", "k"], Duration::from_secs(10));
    let kind = next_kind(&scene.materials[m].kind);
    let line = v.line_starting("edit:", Duration::from_secs(20));
    assert!(line.starts_with(&format!("edit: material {m} is now {}", kind_name(&kind))), "{line}");
    let after = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(60));
    let diff = differing_pixels(&before, &after);
    assert!(diff > 50, "only {diff} pixels changed when material {m} became {}", kind_name(&kind));
    x.xdotool(&["key", "t"], Duration::from_secs(10));
    let line = v.line_starting("scene:", Duration::from_secs(20));
    assert_eq!(line, format!("scene: {}", saved.display()));
    let loaded = irt::io::load(&saved).unwrap();
    let mut want = scene.clone();
    want.materials[m].kind = kind;
    assert_eq!(loaded, want, "the saved scene is the default scene with the one edit");
    x.xdotool(&["key", "Escape"], Duration::from_secs(10));
    v.exits_cleanly(Duration::from_secs(20));
}

/// (f) L selects light 0; a Shift+left drag moves it (the picture changes) and dragging back to
/// the start gives the first picture again, bit for bit.
#[test]
fn a_dragged_light_changes_the_picture_and_dragging_back_restores_it() {
    let _serial = serial();
    let x = Xvfb::start();
    let dir = TempDir::new("f");
    let shot = dir.join("f.png");
    let (mut v, wid) = focused_viewer(&x, &shot, &[]);
    x.xdotool(&["key", "l"], Duration::from_secs(10));
    assert_eq!(v.line_starting("selected:", Duration::from_secs(20)), "selected: light 0");
    let before = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(60));
    x.xdotool(&["mousemove", "--window", &wid, "128", "150"], Duration::from_secs(10));
    x.xdotool(&["keydown", "shift"], Duration::from_secs(10));
    x.xdotool(&["mousedown", "1"], Duration::from_secs(10));
    let drag = |to: &[i32]| {
        for dx in to {
            x.xdotool(
                &["mousemove", "--window", &wid, &(128 + dx).to_string(), "150"],
                Duration::from_secs(10),
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    };
    drag(&[10, 30, 60, 90]);
    let moved = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(60));
    drag(&[60, 20, 0]);
    let back = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(60));
    x.xdotool(&["mouseup", "1"], Duration::from_secs(10));
    x.xdotool(&["keyup", "shift"], Duration::from_secs(10));
    let line = v.line_starting("edit:", Duration::from_secs(20));
    let light = &irt::scene::default_scene().lights[0].position;
    assert!(line.starts_with(&format!("edit: light 0 at ({}, {}, {})", light.x, light.y, light.z)), "{line}");
    let diff = differing_pixels(&before, &moved);
    assert!(diff > 100, "only {diff} pixels changed when the light moved");
    assert_eq!(differing_pixels(&before, &back), 0, "the light dragged back does not give the first picture");
    x.xdotool(&["key", "Escape"], Duration::from_secs(10));
    v.exits_cleanly(Duration::from_secs(20));
}

/// (g) Playback: `irt view scenes/animated.toml --time T --paused` shows the scene at time T,
/// bit for bit what a headless session of the animated scene set to time T traces (the path
/// every playing redraw takes: `Session::set_time`); another time shows another picture.
#[test]
fn a_paused_animated_scene_shows_its_time_bit_for_bit() {
    let _serial = serial();
    let x = Xvfb::start();
    let dir = TempDir::new("g");
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/animated.toml");
    let ctx = common::gpu();
    let mut scene = irt::io::load(&file).unwrap();
    (scene.camera.width, scene.camera.height) = (192, 144);
    let settings = Settings { mode: Mode::conventional(), ..Settings::default() };
    let mut shots = Vec::new();
    for t in ["0", "1.5"] {
        let shot = dir.join(&format!("t{t}.png"));
        let mut v = Viewer::start(
            &x,
            &[
                file.to_str().unwrap(),
                "--size",
                "192x144",
                "--mode",
                "conventional",
                "--time",
                t,
                "--paused",
                "--frames",
                "3",
                "--screenshot",
                shot.to_str().unwrap(),
            ],
        );
        v.exits_cleanly(Duration::from_secs(120));
        let (_, _, got) = decode(&shot);
        let mut s = Session::new(&ctx, &scene, settings.clone()).unwrap();
        s.set_time(&ctx, t.parse().unwrap()).unwrap();
        for _ in 0..3 {
            s.complete_pass(&ctx);
        }
        let want = s.read_image(&ctx).to_srgb8();
        assert_eq!(
            differing_pixels(&got, &want),
            0,
            "time {t}: the window differs from the headless session"
        );
        shots.push(got);
    }
    assert!(differing_pixels(&shots[0], &shots[1]) > 500, "things moved between 0 and 1.5 s");
}

/// Pixels of the `w`-wide RGB pictures `a` and `b` inside `[x0, x1)×[y0, y1)` whose channels
/// differ by more than `levels`.
fn differing_in(a: &[u8], b: &[u8], w: u32, [x0, x1, y0, y1]: [u32; 4], levels: u8) -> usize {
    (y0..y1)
        .flat_map(|y| (x0..x1).map(move |x| 3 * (y * w + x) as usize))
        .filter(|&i| (0..3).any(|c| a[i + c].abs_diff(b[i + c]) > levels))
        .count()
}

/// (h) The default window, as a person meets it: it opens at the size that suits the screen
/// (Xvfb's 1024×768: 853×640, the default camera's 4:3 within 1280×720 and the screen less its
/// margin), with the compact status on, and a drag that starts at its exact centre orbits.
#[test]
fn the_default_window_fits_the_screen_and_a_drag_from_its_centre_orbits() {
    let _serial = serial();
    let x = Xvfb::start();
    let dir = TempDir::new("h");
    let shot = dir.join("h.png");
    let t = Instant::now();
    let mut v = Viewer::start(&x, &["--max-samples", "1", "--screenshot", shot.to_str().unwrap()]);
    let wid = window_id(&x);
    let [w, h] = window_geometry(&x, &wid);
    assert_eq!([w, h], irt::app::present::default_window_size(Some([1024, 768]), 640.0 / 480.0));
    assert_eq!([w, h], [853, 640]);
    focus(&x, &wid);
    let before = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(90));
    assert_eq!(decode(&shot).0, w, "the render follows the window");
    let (cx, cy) = (w / 2, h / 2);
    x.xdotool(&["mousemove", "--window", &wid, &cx.to_string(), &cy.to_string()], Duration::from_secs(10));
    x.xdotool(&["mousedown", "1"], Duration::from_secs(10));
    for dx in [10, 20, 40, 60, 80] {
        let to = (cx + dx).to_string();
        x.xdotool(&["mousemove", "--window", &wid, &to, &(cy + 4).to_string()], Duration::from_secs(10));
        std::thread::sleep(Duration::from_millis(30));
    }
    x.xdotool(&["mouseup", "1"], Duration::from_secs(10));
    let after = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(90));
    let diff = differing_pixels(&before, &after);
    assert!(diff > (w * h / 10) as usize, "only {diff} pixels changed after a drag from the centre");
    x.xdotool(&["key", "Escape"], Duration::from_secs(10));
    v.exits_cleanly(Duration::from_secs(20));
    eprintln!("default window test: {:.1} s", t.elapsed().as_secs_f64());
}

/// (i) The compact status leaves the middle of a 640×480 window free: the window's capture
/// (HUD and all) equals `irt render` of the same camera and size in the middle 50%×50%, within 2
/// levels a channel (the surface's sRGB encoding of the frame buffer rounds apart from the
/// library's 8-bit conversion; no other difference is allowed there), while the top-left corner
/// does differ (the status is drawn). A click on the status opens the panel (the left of the
/// window changes), and `H` closes it again.
#[test]
fn the_compact_status_leaves_the_middle_free_and_a_click_opens_the_panel() {
    let _serial = serial();
    let x = Xvfb::start();
    let dir = TempDir::new("i");
    let shot = dir.join("i.png");
    let (w, h) = (640u32, 480u32);
    let rendered = irt_render(&dir.join("render.png"), "640x480");
    let mut v = Viewer::start(
        &x,
        &["--size", "640x480", "--max-samples", "1", "--screenshot", shot.to_str().unwrap()],
    );
    let wid = window_id(&x);
    focus(&x, &wid);
    // The picture converged (one sample: then the viewer waits, and the window holds still).
    let settled = settled_screenshot(&x, &mut v, &shot, Duration::from_secs(60));
    assert_eq!(differing_pixels(&settled, &rendered), 0, "the traced picture is `irt render`'s");
    std::thread::sleep(Duration::from_millis(500));
    let screen = capture(&x, &wid, &dir.join("screen.png"));
    assert_eq!(screen.len(), rendered.len(), "the capture is the 640×480 window");
    let middle = [w / 4, 3 * w / 4, h / 4, 3 * h / 4];
    let off = differing_in(&screen, &rendered, w, middle, 2);
    assert_eq!(off, 0, "{off} pixels of the window's middle differ from the render by over 2 levels");
    // The status is there, in the corner (its text and backing darken the sky).
    let corner = differing_in(&screen, &rendered, w, [0, w / 4, 0, h / 8], 8);
    assert!(corner > 500, "the compact status is not in the top-left corner ({corner} pixels differ)");
    // A click on it opens the panel, over the left of the window.
    x.xdotool(&["mousemove", "--window", &wid, "30", "14"], Duration::from_secs(10));
    x.xdotool(&["click", "1"], Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(1500));
    let panel = capture(&x, &wid, &dir.join("panel.png"));
    let left = [0, w / 2, h / 4, 3 * h / 4];
    let covered = differing_in(&panel, &rendered, w, left, 8);
    assert!(
        covered > (w / 2 * 3 * h / 8 / 2) as usize,
        "the click did not open the panel ({covered} pixels)"
    );
    assert!(v.alive(), "the click on the status did not reach the HUD");
    x.xdotool(&["key", "h"], Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(1500));
    let closed = capture(&x, &wid, &dir.join("closed.png"));
    assert_eq!(differing_in(&closed, &rendered, w, middle, 2), 0, "H did not close the panel");
    assert!(differing_in(&closed, &rendered, w, left, 8) < covered / 4, "H did not close the panel");
    x.xdotool(&["key", "Escape"], Duration::from_secs(10));
    v.exits_cleanly(Duration::from_secs(20));
}

/// The window's adaptation restarts nothing: a frameless pass traced with S changed part-way
/// (`Session::set_slice`) and conventional frames with the schedule switched between them
/// (`Session::set_schedule`) give the pictures of an unchanged session bit for bit, and a
/// schedule cannot change with a frame in flight.
#[test]
fn changing_the_slice_size_or_the_schedule_keeps_the_picture() {
    use irt::render::Schedule;
    let ctx = common::gpu();
    let (w, h) = (96, 64);
    let mut scene = irt::scene::default_scene();
    (scene.camera.width, scene.camera.height) = (w, h);

    let settings = Settings { mode: Mode::frameless(), max_samples: 1, ..Settings::default() };
    let mut s = Session::new(&ctx, &scene, settings.clone()).unwrap();
    s.set_slice(1000);
    let r = s.step(&ctx);
    assert_eq!(r.slice.unwrap().len, 1000);
    let version = s.camera_version();
    s.set_slice(640);
    let r = s.step(&ctx);
    assert_eq!((r.slice.unwrap().first, r.slice.unwrap().len), (1000, 640), "the pass carries on");
    assert_eq!(s.camera_version(), version, "nothing restarted");
    s.complete_pass(&ctx);
    assert!(s.converged());
    assert_eq!(differing_pixels(&s.read_image(&ctx).to_srgb8(), &headless(settings, w, h, 1)), 0);

    let settings = Settings { mode: Mode::conventional(), max_samples: 3, ..Settings::default() };
    let mut s = Session::new(&ctx, &scene, settings.clone()).unwrap();
    s.complete_pass(&ctx);
    assert!(s.set_schedule(&ctx, Schedule::Plain).unwrap());
    s.complete_pass(&ctx);
    assert!(s.set_schedule(&ctx, Schedule::default()).unwrap());
    assert!(!s.step(&ctx).frame_done, "the queue's frame takes several waves");
    assert!(!s.set_schedule(&ctx, Schedule::Plain).unwrap(), "changed with a frame in flight");
    s.complete_pass(&ctx);
    assert_eq!(s.samples(), 3);
    assert_eq!(differing_pixels(&s.read_image(&ctx).to_srgb8(), &headless(settings, w, h, 3)), 0);
}
