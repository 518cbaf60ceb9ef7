//! `aibr demo` and its report, checked in a real headless browser (Debian's chromium; CI
//! installs it, elsewhere the browser part is skipped with a note when it is missing).

mod common;
use common::*;

use std::path::{Path, PathBuf};
use std::process::Command;

fn chromium() -> Option<PathBuf> {
    ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.exists())
}

fn headless(profile: &Path) -> Command {
    let mut c = Command::new(chromium().unwrap_or_default());
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

/// The values of `attr="..."` in `html`.
fn attributes(html: &str, attr: &str) -> Vec<String> {
    let key = format!("{attr}=\"");
    html.match_indices(&key)
        .filter_map(|(i, _)| {
            let rest = &html[i + key.len()..];
            rest.find('"').map(|end| rest[..end].to_owned())
        })
        .collect()
}

/// A folder that is not a demo report is refused before any work, what it holds left as it
/// was (`--out .` in a project would otherwise lose its `index.html`); a report folder is
/// written again, its sessions reused.
#[test]
fn the_demo_writes_only_into_its_own_report_folder() -> TestResult {
    let out = temp("demo-occupied");
    std::fs::create_dir_all(&out)?;
    let page = out.join("index.html");
    let theirs = "<html><title>someone else's page</title></html>";
    std::fs::write(&page, theirs)?;
    let demo = || aibr().args(["demo", "--quick", "--out"]).arg(&out).output();
    let refused = demo()?;
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success(), "{stderr}");
    assert!(
        stderr.contains("index.html is there") && stderr.contains("not an aibr demo report"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&page)?, theirs);
    assert!(!out.join("sessions").exists());

    std::fs::remove_file(&page)?;
    assert_success(&demo()?);
    let first = std::fs::read_to_string(&page)?;
    // Again into the report it wrote: the same report from the same sessions.
    assert_success(&demo()?);
    let again = std::fs::read_to_string(&page)?;
    let figures = |html: &str| {
        let table = html.split("<table").nth(1)?;
        table.split("</table>").next().map(str::to_owned)
    };
    assert_eq!(figures(&again), figures(&first));
    assert!(figures(&first).is_some());
    assert!(first.contains("--reflections off"), "{first}");
    // It says what active capture's initial views decided, and from what contrast.
    assert!(
        first.contains("<code>--faces-first auto</code>")
            && first.contains("times the median one, against the 2 that decides"),
        "{first}"
    );

    // The renderer's options reach both the measured novel views and the page's renders, and
    // the page says which were taken. (At the quick settings reflections alone change the
    // table but no render the page shows; a deeper refinement changes both.)
    let renders = |dir: &Path| -> std::io::Result<Vec<Vec<u8>>> {
        ["active", "uniform"]
            .iter()
            .flat_map(|s| (0..2).map(move |k| dir.join(format!("{s}-{k}.png"))))
            .map(std::fs::read)
            .collect()
    };
    let before = renders(&out)?;
    let other = aibr()
        .args([
            "demo",
            "--quick",
            "--reflections",
            "on",
            "--reach",
            "6",
            "--out",
        ])
        .arg(&out)
        .output()?;
    assert_success(&other);
    let with = std::fs::read_to_string(&page)?;
    assert!(with.contains("--reflections on"), "{with}");
    assert!(with.contains("up to 6 voxels"), "{with}");
    assert_ne!(figures(&with), figures(&first));
    assert!(
        renders(&out)? != before,
        "the page's renders did not change with the renderer's options"
    );
    let _ = std::fs::remove_dir_all(&out);
    Ok(())
}

#[test]
fn the_demo_report_loads_in_a_browser() -> TestResult {
    let out = temp("demo");
    let run = aibr()
        .args(["demo", "--quick", "--out"])
        .arg(&out)
        .output()?;
    assert_success(&run);
    let stdout = String::from_utf8_lossy(&run.stdout);
    let index = out.join("index.html");
    assert!(stdout.contains(&*index.to_string_lossy()), "{stdout}");
    assert!(
        stdout.contains("active") && stdout.contains("uniform"),
        "{stdout}"
    );

    // Every image and link of the page is a file of the report, and none is empty.
    let html = std::fs::read_to_string(&index)?;
    let srcs = attributes(&html, "src");
    let hrefs = attributes(&html, "href");
    assert!(srcs.len() >= 8, "{srcs:?}");
    for f in srcs.iter().chain(&hrefs) {
        let len = std::fs::metadata(out.join(f))?.len();
        assert!(len > 100, "{f}: {len} bytes");
    }

    let Some(_) = chromium() else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must install chromium (Debian package chromium) for this test"
        );
        eprintln!("SKIP: no chromium; the report was checked without a browser");
        return Ok(());
    };
    let url = format!("file://{}", index.display());
    let dom = headless(&out.join("profile-dom"))
        .args(["--virtual-time-budget=5000", "--dump-dom", &url])
        .output()?;
    let dom = String::from_utf8_lossy(&dom.stdout);
    // The page's script counts the images that loaded with a size.
    let loaded = attributes(&dom, "data-images");
    assert_eq!(
        loaded,
        vec![format!("{}/{}", srcs.len(), srcs.len())],
        "{}",
        &dom[..dom.len().min(400)]
    );

    // And it is not blank: the screenshot has many colours in it.
    let shot = out.join("shot.png");
    let status = headless(&out.join("profile-shot"))
        .args(["--window-size=1200,2000"])
        .arg(format!("--screenshot={}", shot.display()))
        .arg(&url)
        .output()?;
    assert!(status.status.success() || shot.exists());
    let img = image::open(&shot)?.to_rgb8();
    let mut colours: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(
        colours.len() > 200,
        "{} colours: the page looks blank",
        colours.len()
    );
    let _ = std::fs::remove_dir_all(&out);
    Ok(())
}
