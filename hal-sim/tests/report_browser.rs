//! The HTML report in a real browser: `hal-sim demo` writes report.html, headless Chromium
//! (Debian's `chromium`, installed by scripts/install-tools.sh) renders it to a PNG, which must
//! not be blank, and its DOM must hold the titles of the expected plots (the SVGs are inline,
//! so their titles are DOM text).
//!
//! Without chromium the test is skipped with a message, except under `CI=true`, where it fails.

use std::path::Path;
use std::process::Command;

/// Chromium's flags that work headless here (no GPU, no sandbox as root, no network).
fn chromium(profile: &Path) -> Command {
    let mut c = Command::new("chromium");
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
    ])
    .arg(format!("--user-data-dir={}", profile.display()));
    c
}

fn chromium_present() -> bool {
    let present = Command::new("chromium")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !present {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "chromium is missing under CI=true: scripts/install-tools.sh installs it"
        );
        eprintln!(
            "skipping the report browser test: chromium is not installed \
             (apt-get install chromium, or bash scripts/install-tools.sh)"
        );
    }
    present
}

#[test]
fn demo_report_renders_in_headless_chromium() {
    if !chromium_present() {
        return;
    }
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let out = dir.path().join("demo");
    let demo = Command::new(env!("CARGO_BIN_EXE_hal-sim"))
        .args(["demo", "--effect", "gyro/random-walk", "--seed", "4"])
        .args(["--hours", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        demo.status.success(),
        "hal-sim demo failed: {}",
        String::from_utf8_lossy(&demo.stderr)
    );
    let html = out.join("report.html");
    let url = format!("file://{}", html.display());

    // The screenshot: a rendered page has text, tables, lines and shaded bands, so thousands of
    // distinct colours (anti-aliasing); a blank or failed page has a handful.
    let png_path = dir.path().join("report.png");
    let profile = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let shot = chromium(profile.path())
        .arg("--window-size=1000,3000")
        .arg(format!("--screenshot={}", png_path.display()))
        .arg(&url)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        shot.status.success() && png_path.is_file(),
        "chromium --screenshot failed: {}",
        String::from_utf8_lossy(&shot.stderr)
    );
    let file = std::fs::File::open(&png_path).unwrap_or_else(|e| panic!("{e}"));
    let mut reader = png::Decoder::new(file)
        .read_info()
        .unwrap_or_else(|e| panic!("{e}"));
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader
        .next_frame(&mut buf)
        .unwrap_or_else(|e| panic!("{e}"));
    let px = info.color_type.samples();
    let pixels: Vec<&[u8]> = buf[..info.buffer_size()].chunks(px).collect();
    let mut distinct: Vec<&[u8]> = pixels.clone();
    distinct.sort_unstable();
    distinct.dedup();
    let ink = pixels
        .iter()
        .filter(|p| p.iter().take(3).any(|&c| c < 200))
        .count();
    eprintln!(
        "report.png: {}x{}, {} distinct colours, {:.2} % ink",
        info.width,
        info.height,
        distinct.len(),
        100.0 * ink as f64 / pixels.len() as f64
    );
    assert_eq!((info.width, info.height), (1000, 3000));
    assert!(
        distinct.len() > 200,
        "blank-looking screenshot: {} colours",
        distinct.len()
    );
    assert!(
        ink * 100 > pixels.len(),
        "under 1 % of the page is drawn: {ink} of {} pixels",
        pixels.len()
    );

    // The DOM after rendering holds every expected plot title.
    let profile = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let dom = chromium(profile.path())
        .arg("--dump-dom")
        .arg(&url)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(dom.status.success(), "chromium --dump-dom failed");
    let dom = String::from_utf8_lossy(&dom.stdout);
    for title in [
        "imu-ident demo: find the missing effect",
        "Innovation whiteness: ACF of nu/sqrt(S), 99 % band",
        "Windowed NIS (10-min mean), 99 % chi-square band",
        "nominal: ACF of the estimated gyro error vs the model",
        "nominal: tilt error against ±3 sigma",
        "Online identification: gyro 0 (gauss-markov) sigma",
        // The legend of the shaded Cramér-Rao interval of the identified parameters.
        "95 % Cramér-Rao interval",
        "what the fit means",
    ] {
        assert!(dom.contains(title), "no {title:?} in the rendered DOM");
    }
}
