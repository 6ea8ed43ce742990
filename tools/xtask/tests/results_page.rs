//! docs/results/index.html (the generated results page) opened in headless Chromium, Debian's `chromium` that
//! `cargo xtask setup` installs (`CHROMIUM` names another binary). Offline flags and a fresh profile: the
//! machine has no network, and the page must need none. Fails on any console error or uncaught exception, on an
//! image that did not load, and on a comparison control (swap, split slider, picking an image, exposure, zoom)
//! that does not change what is displayed. Saves a screenshot of the whole page as out/results-page.png.
//!
//! headless_chrome drives the browser over the DevTools protocol: a synchronous API (no async runtime for
//! one test), console and log events, element screenshots; with its default `offline` feature and without
//! `fetch` it neither downloads the protocol nor a browser.

use headless_chrome::protocol::cdp::types::Event;
use headless_chrome::protocol::cdp::Log::LogEntryLevel;
use headless_chrome::protocol::cdp::Page::{self, CaptureScreenshotFormatOption};
use headless_chrome::protocol::cdp::Runtime::ConsoleAPICalledEventTypeOption;
use headless_chrome::{Browser, LaunchOptions, Tab};
use std::ffi::OsStr;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn chromium() -> PathBuf {
    let path = std::env::var_os("CHROMIUM").map(PathBuf::from).unwrap_or_else(|| PathBuf::from("/usr/bin/chromium"));
    assert!(
        path.is_file(),
        "{} not found: `cargo xtask setup` installs Debian's chromium (or set CHROMIUM to a Chromium binary)",
        path.display()
    );
    path
}

/// Evaluate a JavaScript expression that returns a string.
fn eval(tab: &Tab, js: &str) -> String {
    let v = tab.evaluate(js, false).unwrap_or_else(|e| panic!("evaluating {js}: {e}"));
    match v.value {
        Some(serde_json::Value::String(s)) => s,
        other => panic!("{js} gave {other:?}"),
    }
}

/// Set an input's value and fire its `input` event, as a user's change does.
fn set_input(tab: &Tab, id: &str, value: &str) {
    let js = format!(
        "(() => {{ const e = document.getElementById('{id}'); if (!e) return 'missing'; e.value = '{value}'; \
         e.dispatchEvent(new Event('input')); return String(e.value); }})()"
    );
    assert_eq!(eval(tab, &js), value, "setting #{id} to {value}");
}

#[test]
fn results_page_works_in_headless_chromium() {
    let page = root().join("docs/results/index.html");
    assert!(page.is_file(), "{} is missing: run `cargo xtask report --sweep readme`", page.display());
    let profile = std::env::temp_dir().join(format!("results-page-chromium-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&profile);
    std::fs::create_dir_all(&profile).unwrap();
    let args: Vec<&OsStr> = [
        "--disable-gpu",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
    ]
    .iter()
    .map(OsStr::new)
    .collect();
    let options = LaunchOptions::default_builder()
        .path(Some(chromium()))
        .headless(true)
        .sandbox(false)
        .window_size(Some((1400, 1000)))
        .user_data_dir(Some(profile.clone()))
        .args(args)
        .idle_browser_timeout(Duration::from_secs(300))
        .build()
        .expect("launch options");
    let browser = Browser::new(options).expect("starting chromium");
    let tab = browser.new_tab().expect("a tab");
    tab.set_default_timeout(Duration::from_secs(120));

    // Every console error, uncaught exception and error-level log entry (a failed load among them).
    let errors = Arc::new(Mutex::new(Vec::<String>::new()));
    let sink = Arc::clone(&errors);
    tab.add_event_listener(Arc::new(move |event: &Event| {
        let message = match event {
            Event::RuntimeConsoleAPICalled(e) if e.params.Type == ConsoleAPICalledEventTypeOption::Error => {
                Some(format!("console.error: {:?}", e.params.args.iter().map(|a| &a.value).collect::<Vec<_>>()))
            }
            Event::RuntimeExceptionThrown(e) => Some(format!("exception: {:?}", e.params.exception_details)),
            Event::LogEntryAdded(e) if e.params.entry.level == LogEntryLevel::Error => {
                Some(format!("log: {} {:?}", e.params.entry.text, e.params.entry.url))
            }
            _ => None,
        };
        if let Some(m) = message {
            sink.lock().unwrap().push(m);
        }
    }))
    .unwrap();
    tab.enable_log().unwrap();
    tab.enable_runtime().unwrap();
    tab.navigate_to(&format!("file://{}", page.canonicalize().unwrap().display()))
        .and_then(|t| t.wait_until_navigated())
        .expect("loading the page");

    // Every image loaded (data URIs: a broken one has no natural size), the comparison's too.
    let images = eval(
        &tab,
        "JSON.stringify(Array.from(document.images).map(i => [i.id || i.alt, i.complete && i.naturalWidth > 0]))",
    );
    let images: Vec<(String, bool)> = serde_json::from_str(&images).unwrap();
    let broken: Vec<&String> = images.iter().filter(|(_, ok)| !ok).map(|(id, _)| id).collect();
    assert!(images.len() >= 30, "only {} images on the page", images.len());
    assert!(broken.is_empty(), "images that did not load: {broken:?}");

    // Each scene's comparison: every control changes the displayed image.
    let scenes: Vec<String> = serde_json::from_str(&eval(
        &tab,
        "JSON.stringify(Array.from(document.querySelectorAll('.compare-box')).map(b => b.dataset.scene))",
    ))
    .unwrap();
    assert!(scenes.len() >= 6, "comparison boxes: {scenes:?}");
    let shot = |id: &str| -> Vec<u8> {
        // An image given a new data URI decodes asynchronously: wait for the comparison's images first.
        let decoded = format!(
            "Promise.all(Array.from(document.querySelectorAll('#{id} img')).map(i => i.decode())).then(() => 'ok')"
        );
        let v = tab.evaluate(&decoded, true).unwrap_or_else(|e| panic!("decoding #{id}'s images: {e}"));
        assert_eq!(v.value, Some(serde_json::Value::String("ok".into())), "#{id}'s images");
        // The element scrolled into view, clipped in page coordinates.
        let rect = eval(
            &tab,
            &format!(
                "(() => {{ const e = document.getElementById('{id}'); e.scrollIntoView(); \
                 const r = e.getBoundingClientRect(); \
                 return JSON.stringify([r.left + window.scrollX, r.top + window.scrollY, r.width, r.height]); }})()"
            ),
        );
        let [x, y, width, height]: [f64; 4] = serde_json::from_str(&rect).unwrap();
        assert!(width > 0.0 && height > 0.0, "#{id} is {width}×{height}");
        let clip = Page::Viewport { x, y, width, height, scale: 1.0 };
        tab.capture_screenshot(CaptureScreenshotFormatOption::Png, None, Some(clip), true)
            .unwrap_or_else(|e| panic!("screenshot of #{id}: {e}"))
    };
    for stem in &scenes {
        let cmp = format!("cmp-{stem}");
        let mut last = shot(&cmp);
        let changed = |what: &str, last: &mut Vec<u8>| {
            let now = shot(&cmp);
            assert!(now != *last, "{stem}: {what} did not change the displayed comparison");
            *last = now;
        };
        // A click event on the button (a mouse click at its centre could land on the sticky control bar).
        let clicked = format!("(() => {{ document.getElementById('{cmp}-swap').click(); return 'ok'; }})()");
        assert_eq!(eval(&tab, &clicked), "ok");
        changed("the swap button", &mut last);
        set_input(&tab, &format!("{cmp}-slider"), "10");
        changed("the split slider", &mut last);
        // Pick the right image's heat map against the triangles.
        let heat = eval(
            &tab,
            &format!(
                "(() => {{ const s = document.getElementById('{cmp}-pick-b'); \
                 const o = Array.from(s.options).find(o => o.value.endsWith('-tri') && o.value !== s.value); \
                 return o ? o.value : 'none'; }})()"
            ),
        );
        assert_ne!(heat, "none", "{stem}: no heat map to pick");
        set_input(&tab, &format!("{cmp}-pick-b"), &heat);
        changed("picking another image", &mut last);
    }
    // Exposure and zoom act on every scene's comparison; check the first.
    let first = format!("cmp-{}", scenes[0]);
    set_input(
        &tab,
        &format!("{first}-pick-b"),
        &eval(&tab, &format!("document.getElementById('{first}-pick-a').value")),
    );
    let before = shot(&first);
    set_input(&tab, "exposure", "2");
    let brighter = shot(&first);
    assert!(brighter != before, "the exposure control did not change the displayed image");
    let width =
        |tab: &Tab| eval(tab, &format!("String(document.getElementById('{first}').getBoundingClientRect().width)"));
    let narrow: f64 = width(&tab).parse().unwrap();
    set_input(&tab, "zoom", "4");
    let wide: f64 = width(&tab).parse().unwrap();
    assert!(wide > 1.5 * narrow, "zoom 2 → 4 left the comparison {narrow} → {wide} px wide");
    set_input(&tab, "exposure", "0");
    set_input(&tab, "zoom", "2");

    let png = tab.capture_screenshot(CaptureScreenshotFormatOption::Png, None, None, true).expect("a screenshot");
    let out = root().join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("results-page.png"), &png).unwrap();
    let errors = errors.lock().unwrap().clone();
    drop(browser);
    let _ = std::fs::remove_dir_all(&profile);
    assert!(errors.is_empty(), "the page logged errors:\n{}", errors.join("\n"));
}
