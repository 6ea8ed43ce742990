//! The viewer under Xvfb: open a window, present a few frames, screenshot the X screen with `xwd`
//! and compare the presented pixels with the headless render of the same scene and size.
//!
//! Needs `Xvfb` (package xvfb) and `xwd` (package x11-apps); `cargo xtask test` installs both.
//! The window is placed at (0, 0) and Xvfb runs without a window manager (no decorations), so
//! the window's pixels are the top-left corner of the screen.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const W: u32 = 128;
const H: u32 = 96;

struct Xvfb {
    child: Child,
    display: String,
}

impl Xvfb {
    fn start() -> Xvfb {
        let exe = which("Xvfb").expect("Xvfb not found: install xvfb (`cargo xtask test` does)");
        // A display number no other server (or parallel test run) uses.
        let n = (90..190)
            .map(|i| i + std::process::id() % 50)
            .find(|n| {
                !Path::new(&format!("/tmp/.X11-unix/X{n}")).exists() && !Path::new(&format!("/tmp/.X{n}-lock")).exists()
            })
            .expect("no free X display number");
        let display = format!(":{n}");
        let child = Command::new(exe)
            .args([&display, "-screen", "0", "320x240x24", "-nolisten", "tcp"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("starting Xvfb");
        let socket = PathBuf::from(format!("/tmp/.X11-unix/X{n}"));
        let t0 = Instant::now();
        while !socket.exists() {
            assert!(t0.elapsed() < Duration::from_secs(20), "Xvfb {display} did not start within 20 s");
            std::thread::sleep(Duration::from_millis(50));
        }
        Xvfb { child, display }
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn which(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH")?.to_str()?.split(':').map(|d| Path::new(d).join(name)).find(|p| p.is_file())
}

/// A decoded XWD screenshot: RGB8 rows.
struct Screenshot {
    width: usize,
    height: usize,
    rgb: Vec<[u8; 3]>,
}

/// Decode the ZPixmap, 24/32-bit TrueColor XWD that `xwd -root` writes for an Xvfb screen of depth 24.
fn decode_xwd(bytes: &[u8]) -> Screenshot {
    let field = |i: usize| u32::from_be_bytes(bytes[4 * i..4 * i + 4].try_into().unwrap());
    assert!(bytes.len() >= 100, "xwd output too short ({} bytes)", bytes.len());
    let (header_size, version, format) = (field(0) as usize, field(1), field(2));
    assert_eq!((version, format), (7, 2), "expected an XWD version 7 ZPixmap");
    let (width, height) = (field(4) as usize, field(5) as usize);
    let (byte_order, bpp, bytes_per_line) = (field(7), field(11), field(12) as usize);
    let masks = [field(14), field(15), field(16)];
    let ncolors = field(19) as usize;
    assert_eq!(bpp, 32, "expected 32 bits per pixel");
    let data = &bytes[header_size + 12 * ncolors..];
    assert!(data.len() >= height * bytes_per_line, "xwd pixel data truncated");
    let channel = |p: u32, m: u32| ((p & m) >> m.trailing_zeros()) as u8;
    let mut rgb = Vec::with_capacity(width * height);
    for y in 0..height {
        for x in 0..width {
            let b: [u8; 4] = data[y * bytes_per_line + 4 * x..][..4].try_into().unwrap();
            let p = if byte_order == 0 { u32::from_le_bytes(b) } else { u32::from_be_bytes(b) };
            rgb.push([channel(p, masks[0]), channel(p, masks[1]), channel(p, masks[2])]);
        }
    }
    Screenshot { width, height, rgb }
}

fn demo() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_demo"));
    c.env("ENGINE_VALIDATION", "1");
    c
}

#[test]
fn viewer_presents_the_headless_image() {
    let xwd = which("xwd").expect("xwd not found: install x11-apps (`cargo xtask test` does)");
    let out = std::env::temp_dir().join(format!("engine-window-test-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();

    // Headless reference of the same scene, size and settings.
    // `none`: the test compares presentation with the headless path, not shading (and isg's 40 viewer
    // frames would cost minutes on lavapipe).
    let size = [format!("--width={W}"), format!("--height={H}"), "--technique=none".to_string()];
    let status = demo()
        .args(&size)
        .args(["--frames=1", "--name=headless", "--out"])
        .arg(&out)
        .stdout(Stdio::null())
        .status()
        .expect("running demo");
    assert!(status.success(), "headless demo failed");
    let (pw, ph, headless) = engine::output::read_png(&out.join("headless.png")).expect("reading the headless PNG");
    assert_eq!((pw, ph), (W, H));

    let x = Xvfb::start();
    let mut viewer = demo()
        .args(&size)
        .args(["--window", "--exit-after=40"])
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::piped())
        .spawn()
        .expect("starting the viewer");
    // Wait until a few frames were presented (the first ones may race the window mapping).
    let mut lines = BufReader::new(viewer.stdout.take().unwrap()).lines();
    let mut presented = 0;
    while presented < 3 {
        match lines.next() {
            Some(Ok(l)) => {
                presented = l.strip_prefix("presented frame ").and_then(|n| n.parse().ok()).unwrap_or(presented)
            }
            _ => panic!("the viewer stopped before presenting 3 frames: {:?}", viewer.wait()),
        }
    }
    let shot = Command::new(xwd).args(["-root", "-silent", "-display", &x.display]).output().expect("running xwd");
    assert!(shot.status.success(), "xwd failed: {}", String::from_utf8_lossy(&shot.stderr));
    let still_running = viewer.try_wait().expect("viewer status").is_none();
    // Drain stdout so the viewer never blocks on a full pipe, then require a clean exit
    // (validation errors or leaks make it exit non-zero).
    let last = lines.map_while(Result::ok).last();
    let status = viewer.wait().expect("viewer");
    assert!(status.success(), "viewer exited with {status} after {last:?}");
    assert!(still_running, "the viewer had already closed its window when the screenshot was taken");

    let s = decode_xwd(&shot.stdout);
    assert!(s.width >= W as usize && s.height >= H as usize);
    let mut worst = 0u8;
    let mut differing = 0usize;
    for y in 0..H as usize {
        for x in 0..W as usize {
            let p = s.rgb[y * s.width + x];
            let q = &headless[4 * (y * W as usize + x)..][..3];
            let d = (0..3).map(|c| p[c].abs_diff(q[c])).max().unwrap();
            worst = worst.max(d);
            differing += (d > 0) as usize;
        }
    }
    eprintln!("presented vs headless: max difference {worst}/255, {differing} of {} pixels differ", W * H);
    // Same renderer, camera and size, a NEAREST blit from RGBA8 into an 8-bit UNORM swapchain image and
    // a depth-24 X screen: the presented pixels must be the headless ones exactly (lavapipe: 0). One
    // level of slack for drivers whose blit converts through float.
    assert!(worst <= 1, "presented image differs from the headless render: max {worst}/255, {differing} pixels differ");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn xwd_decoder_reads_a_synthetic_image() {
    // 2×1 image, LSB-first 32-bit pixels, masks R=0xff0000 G=0xff00 B=0xff, no colormap.
    let mut b = Vec::new();
    let header: [u32; 25] =
        [100, 7, 2, 24, 2, 1, 0, 0, 32, 0, 32, 32, 8, 4, 0xff0000, 0xff00, 0xff, 8, 256, 0, 2, 1, 0, 0, 0];
    for f in header {
        b.extend_from_slice(&f.to_be_bytes());
    }
    b.extend_from_slice(&0x00112233u32.to_le_bytes());
    b.extend_from_slice(&0x00ff0001u32.to_le_bytes());
    let s = decode_xwd(&b);
    assert_eq!((s.width, s.height), (2, 1));
    assert_eq!(s.rgb, vec![[0x11, 0x22, 0x33], [0xff, 0x00, 0x01]]);
}
