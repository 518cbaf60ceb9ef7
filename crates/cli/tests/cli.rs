//! The `aibr` binary end to end: capture, kill and resume, bad input.

mod common;
use common::*;

use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

const SMALL: [&str; 8] = [
    "--rig",
    "sim:lambertian",
    "--initial",
    "5",
    "--max",
    "11",
    "--grid",
    "24",
];

/// `(pan_rad, image_crc32)` of every view of a session.
fn views(dir: &Path) -> Result<Vec<(f64, u64)>, Box<dyn std::error::Error>> {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("session.json"))?)?;
    Ok(v["views"]
        .as_array()
        .ok_or("no views")?
        .iter()
        .map(|r| {
            (
                r["pan_rad"].as_f64().unwrap_or(f64::NAN),
                r["image_crc32"].as_u64().unwrap_or(0),
            )
        })
        .collect())
}

/// Runs `aibr capture ARGS --out DIR` and checks that it succeeded.
fn capture_ok(args: &[&str], dir: &Path) -> TestResult {
    let status = aibr()
        .arg("capture")
        .args(args)
        .arg("--out")
        .arg(dir)
        .stdout(Stdio::null())
        .status()?;
    assert!(status.success(), "aibr capture {args:?} failed");
    Ok(())
}

fn count_views(dir: &Path) -> usize {
    views(dir).map(|v| v.len()).unwrap_or(0)
}

/// Kill the capture in the middle, resume, and end with the same views as an uninterrupted
/// run; no file lost or half-written.
#[test]
fn killed_capture_resumes_to_the_same_views() -> TestResult {
    let whole = temp("whole");
    capture_ok(&SMALL, &whole)?;
    let expected = views(&whole)?;
    assert_eq!(expected.len(), 11);

    let killed = temp("killed");
    let mut child = aibr()
        .arg("capture")
        .args(SMALL)
        .arg("--out")
        .arg(&killed)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()?;
    // Kill it once the active phase has begun (more views than the initial 5).
    let start = Instant::now();
    while count_views(&killed) < 7 {
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            return Err("the capture made no progress".into());
        }
        if child.try_wait()?.is_some() {
            return Err("the capture finished before it could be killed".into());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill()?;
    child.wait()?;
    let partial = views(&killed)?;
    assert!(
        partial.len() >= 7 && partial.len() < 11,
        "{} views when killed",
        partial.len()
    );
    assert_eq!(
        partial[..],
        expected[..partial.len()],
        "the views before the kill are the same"
    );

    // Resuming refuses different options, then continues with the same ones.
    let wrong = aibr()
        .arg("capture")
        .args([
            "--rig",
            "sim:lambertian",
            "--initial",
            "5",
            "--max",
            "12",
            "--grid",
            "24",
        ])
        .arg("--out")
        .arg(&killed)
        .arg("--resume")
        .output()?;
    assert!(!wrong.status.success());
    let stderr = String::from_utf8_lossy(&wrong.stderr);
    assert!(
        stderr.contains("was captured with max 11, not 12") && stderr.contains("same options"),
        "{stderr}"
    );
    let status = aibr()
        .arg("capture")
        .args(SMALL)
        .arg("--out")
        .arg(&killed)
        .arg("--resume")
        .stdout(Stdio::null())
        .status()?;
    assert!(status.success());
    assert_eq!(views(&killed)?, expected);
    // Every view file is whole (its checksum matches) and no temporary file is left.
    let session = aibr::Session::open(&killed)?;
    assert_eq!(session.load_views()?.len(), 11);
    for sub in ["", "views", "masks"] {
        for entry in std::fs::read_dir(killed.join(sub))? {
            let name = entry?.file_name().to_string_lossy().into_owned();
            assert!(
                !name.contains(".tmp-"),
                "temporary file {name} left in {sub}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&whole);
    let _ = std::fs::remove_dir_all(&killed);
    Ok(())
}

/// The depth refinement's penalised deep search (`docs/render.md`), as `render` and `eval`
/// take it; its last value is the penalty.
const DEEP_SEARCH: [&str; 6] = [
    "--reach",
    "8",
    "--refine-steps",
    "12",
    "--reach-penalty",
    "0.3",
];

#[test]
fn reconstruct_and_render_a_session() -> TestResult {
    let dir = temp("render");
    let out = aibr()
        .arg("capture")
        .args([
            "--rig",
            "sim:chair",
            "--initial",
            "6",
            "--max",
            "6",
            "--grid",
            "24",
        ])
        .arg("--out")
        .arg(&dir)
        .arg("--json")
        .output()?;
    assert_success(&out);
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout)?;
    assert_eq!(summary["views"].as_array().map(|v| v.len()), Some(6));
    assert!(summary["timings_ms"]["capture_ms"].as_f64().is_some());

    // `aibr reconstruct` of the session with `args`; and whether a run was refused for
    // `reason`.
    let reconstruct = |args: &[&str]| aibr().arg("reconstruct").arg(&dir).args(args).output();
    let refused = |out: &std::process::Output, reason: &str| {
        !out.status.success() && String::from_utf8_lossy(&out.stderr).contains(reason)
    };
    // Its JSON summary at 32^3, with `args`.
    let summary_with = |args: &[&str]| -> Result<serde_json::Value, Box<dyn std::error::Error>> {
        let out = reconstruct(&[&["--grid", "32", "--json"], args].concat())?;
        assert_success(&out);
        Ok(serde_json::from_slice(&out.stdout)?)
    };
    let summary = summary_with(&[])?;
    assert_eq!(summary["algorithm"], "voxel coloring");
    assert!(summary["timings_ms"]["coloring_ms"].as_f64().is_some());
    let ply = std::fs::read(dir.join("model.ply"))?;
    assert!(ply.starts_with(b"ply\nformat binary_little_endian 1.0\n"));
    let header = |ply: &[u8]| String::from_utf8_lossy(&ply[..ply.len().min(400)]).into_owned();
    let n = summary["voxels"].as_u64().ok_or("no voxel count")?;
    assert!(header(&ply).contains(&format!("element vertex {n}\n")));
    assert!(!header(&ply).contains("element face"));
    // The same model as cubes: eight vertices a voxel, and faces.
    assert_eq!(summary_with(&["--cubes"])?["voxels"], summary["voxels"]);
    let cubes = std::fs::read(dir.join("model.ply"))?;
    assert!(header(&cubes).contains(&format!("element vertex {}\n", 8 * n)));
    assert!(header(&cubes).contains("element face "));
    // The plain sweep asks every view, and so keeps another model.
    let voxels = |args: &[&str]| -> Result<serde_json::Value, Box<dyn std::error::Error>> {
        Ok(summary_with(args)?["voxels"].clone())
    };
    assert_eq!(voxels(&["--behind-hull", "-0.3"])?, summary["voxels"]);
    assert_ne!(voxels(&["--behind-hull", "off"])?, summary["voxels"]);
    assert!(refused(&reconstruct(&["--behind-hull", "1.5"])?, "`1.5`"));
    // Sampling inside the footprints: inset 0 is the default, an inset judges fewer voxels
    // and keeps another model, and an inset past the library's range is refused.
    assert_eq!(voxels(&["--sample-inset", "0"])?, summary["voxels"]);
    assert_ne!(voxels(&["--sample-inset", "1"])?, summary["voxels"]);
    let before = std::fs::read(dir.join("model.ply"))?;
    assert!(refused(&reconstruct(&["--sample-inset", "9"])?, "`9`"));
    assert!(refused(&reconstruct(&["--sample-inset", "NaN"])?, "`NaN`"));
    assert_eq!(std::fs::read(dir.join("model.ply"))?, before);
    // The tops refined: the same sweep, then tops moved down, each clearing at least the
    // voxel it stood in and setting only its new place, so the model loses voxels; without
    // the flag no summary.
    assert!(summary["refine_tops"].is_null());
    let refined = summary_with(&["--refine-tops"])?;
    let count = |key: &str| refined["refine_tops"][key].as_u64().unwrap_or(0);
    assert!(
        count("judged") > 0 && count("judged") <= count("tops"),
        "{refined}"
    );
    assert!(count("moved") <= count("judged") && count("cleared") >= count("moved"));
    let net = refined["voxels"].as_i64().unwrap_or(0) - summary["voxels"].as_i64().unwrap_or(0);
    assert!(count("moved") > 0, "{refined}");
    assert!(-(count("cleared") as i64) <= net && net < 0, "{refined}");
    assert_eq!(count("walled"), 0, "{refined}");
    // The same moves with their steps walled: the walls only add voxels.
    let walled = summary_with(&["--refine-tops", "--walls"])?;
    let walls = walled["refine_tops"]["walled"].as_u64().unwrap_or(0);
    assert_eq!(
        walled["refine_tops"]["moved"],
        refined["refine_tops"]["moved"]
    );
    assert_eq!(
        walled["voxels"].as_u64(),
        refined["voxels"].as_u64().map(|v| v + walls),
        "{walled}"
    );
    assert!(refused(&reconstruct(&["--walls"])?, "--refine-tops"));
    // The column test: without the flag no summary; with it, tops passed over and another
    // model.
    assert!(summary["column_test"].is_null());
    let column = summary_with(&["--column-test"])?;
    assert!(column["column_test"]["sunk"].as_u64() > Some(0), "{column}");
    assert_ne!(column["voxels"], summary["voxels"]);

    // `aibr render` of the session with `args`, writing to `to`.
    let render = |args: &[&str], to: &Path| {
        aibr()
            .arg("render")
            .arg(&dir)
            .args(args)
            .arg("-o")
            .arg(to)
            .output()
    };

    // The single view every later render is compared with.
    let view = ["--pan", "-33.5", "--grid", "32"];
    let png = dir.join("novel.png");
    let exr = dir.join("novel.exr");
    let coverage = dir.join("coverage.png");
    let path = |p: &Path| {
        p.to_str()
            .map(str::to_owned)
            .ok_or("a temporary path is not UTF-8")
    };
    let (exr_arg, coverage_arg) = (path(&exr)?, path(&coverage)?);
    let extras = ["--depth", &exr_arg, "--coverage", &coverage_arg];
    assert_success(&render(&[&view[..], &extras].concat(), &png)?);
    let rendered = image::open(&png)?.to_rgb8();
    assert_eq!((rendered.width(), rendered.height()), (640, 480));
    assert!(std::fs::metadata(&exr)?.len() > 1000);
    // The coverage has the three levels only: the model is met on the object, and the
    // backdrop is rendered on the focal surface.
    let coverage = image::open(&coverage)?.to_luma8();
    assert!(coverage.pixels().all(|p| [0, 128, 255].contains(&p.0[0])));
    let geometry = coverage.pixels().filter(|p| p.0[0] == 255).count();
    assert!(geometry > 2_000, "{geometry} geometry pixels");
    assert!(coverage.pixels().any(|p| p.0[0] == 128));

    // How many pixels on the model's surface differ between `other` and the first render;
    // the others, rendered on the focal surface, must be the same.
    let changed_on_surface = |other: &image::RgbImage| {
        let mut changed = 0;
        for ((p, r), c) in other.pixels().zip(rendered.pixels()).zip(coverage.pixels()) {
            if c.0[0] == 255 {
                changed += usize::from(p != r);
            } else {
                assert_eq!(p, r);
            }
        }
        changed
    };
    // Without the refinement only the pixels on the model's surface change.
    let plain = dir.join("plain.png");
    assert_success(&render(&[&view[..], &["--no-refine"]].concat(), &plain)?);
    let changed = changed_on_surface(&image::open(&plain)?.to_rgb8());
    assert!(
        changed > geometry / 2,
        "{changed} of {geometry} refined pixels changed"
    );
    // The refinement's reach: the default given by name renders the same image; a deeper
    // one changes only pixels on the model's surface; one out of range, or with the
    // refinement off, is refused and writes nothing.
    let four = dir.join("reach4.png");
    assert_success(&render(&[&view[..], &["--reach", "4"]].concat(), &four)?);
    assert_eq!(image::open(&four)?.to_rgb8(), rendered);
    let deep = dir.join("reach8.png");
    assert_success(&render(&[&view[..], &["--reach", "8"]].concat(), &deep)?);
    let moved = changed_on_surface(&image::open(&deep)?.to_rgb8());
    assert!(moved > 0, "a reach of 8 voxels changed no pixel");
    // In more depths, with and without a penalty on those beyond 4 voxels: other surface
    // pixels again, and the penalty changes some.
    let mut searched = Vec::new();
    for penalty in ["0", "0.3"] {
        let out = dir.join(format!("penalty{penalty}.png"));
        let deep_search = [&view[..], &DEEP_SEARCH[..5], &[penalty]].concat();
        assert_success(&render(&deep_search, &out)?);
        let image = image::open(&out)?.to_rgb8();
        assert!(changed_on_surface(&image) > 0);
        searched.push(image);
    }
    assert_ne!(searched[0], searched[1]);
    // Mirrors taken as reflections: a pixel can change only on the model's surface.
    let mirrored = dir.join("mirrored.png");
    assert_success(&render(
        &[&view[..], &["--reflections", "on"]].concat(),
        &mirrored,
    )?);
    changed_on_surface(&image::open(&mirrored)?.to_rgb8());
    // The occlusion tolerance: the default given by name renders the same image; a wider one
    // lets more sources blend at some surface points, and nowhere else.
    let tolerance = |voxels: &str| -> Result<image::RgbImage, Box<dyn std::error::Error>> {
        let out = dir.join(format!("occlusion{voxels}.png"));
        assert_success(&render(
            &[&view[..], &["--occlusion-tolerance", voxels]].concat(),
            &out,
        )?);
        Ok(image::open(&out)?.to_rgb8())
    };
    assert_eq!(tolerance("2")?, rendered);
    assert!(changed_on_surface(&tolerance("4")?) > 0);
    let refused_reach = dir.join("reach_refused.png");
    for (bad, named) in [
        (&["--reach=-1"][..], "--reach"),
        (&["--reach", "65"], "--reach"),
        (&["--reach", "6", "--no-refine"], "--reach"),
        (&["--refine-steps", "1"], "--refine-steps"),
        (&["--refine-steps", "65"], "--refine-steps"),
        (&["--refine-steps", "12", "--no-refine"], "--refine-steps"),
        (&["--reach-penalty=-0.1"], "--reach-penalty"),
        (&["--reach-penalty", "NaN"], "--reach-penalty"),
        (&["--occlusion-tolerance=-1"], "--occlusion-tolerance"),
        (&["--occlusion-tolerance", "65"], "--occlusion-tolerance"),
        (&["--occlusion-tolerance", "inf"], "--occlusion-tolerance"),
        (
            &["--reach-penalty", "0.3", "--no-refine"],
            "--reach-penalty",
        ),
        (
            &["--refine-pair", "nearest", "--no-refine"],
            "--refine-pair",
        ),
    ] {
        let out = render(&[&view[..], bad].concat(), &refused_reach)?;
        assert!(!out.status.success(), "{bad:?} was accepted");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(named),
            "{bad:?}"
        );
    }
    assert!(!refused_reach.exists());
    // From the shell as reconstructed instead of closed and filled.
    let shell = dir.join("shell.png");
    assert_success(&render(&[&view[..], &["--no-fill"]].concat(), &shell)?);
    assert_eq!(image::open(&shell)?.to_rgb8().dimensions(), (640, 480));

    // A sweep renders every angle into a folder, the one at -33.5 as the single render did.
    let frames = dir.join("frames");
    let sweep = ["--sweep", "-35:-32:0.5", "--grid", "32"];
    let out = render(&sweep, &frames)?;
    assert_success(&out);
    let mut names: Vec<String> = std::fs::read_dir(&frames)?
        .map(|e| e.map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect::<Result<_, _>>()?;
    names.sort();
    let expected: Vec<String> = (0..7).map(|i| format!("frame_{i:04}.png")).collect();
    assert_eq!(names, expected);
    let third = image::open(frames.join("frame_0003.png"))?.to_rgb8();
    assert_eq!(third, rendered);
    assert!(String::from_utf8_lossy(&out.stdout).contains("7 frames"));
    // Run again, it refuses to overwrite the frames, and names the first.
    let before = std::fs::read(frames.join("frame_0000.png"))?;
    assert!(refused(&render(&sweep, &frames)?, "frame_0000.png exists"));
    assert_eq!(std::fs::read(frames.join("frame_0000.png"))?, before);
    // A sweep that leaves the range is refused before anything is written; so is one that
    // does not parse, naming the part at fault.
    let far = dir.join("far");
    assert!(refused(
        &render(&["--sweep", "150:200:10"], &far)?,
        "outside the range"
    ));
    assert!(refused(
        &render(&["--sweep", "10:0:5"], &far)?,
        "STEP must be non-zero"
    ));
    assert!(!far.exists());

    // An angle outside the turntable's range is refused and writes nothing.
    let bad = dir.join("bad.png");
    assert!(refused(
        &render(&["--pan", "175"], &bad)?,
        "outside the range"
    ));
    assert!(!bad.exists());
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[test]
fn bad_sessions_are_refused_and_left_alone() -> TestResult {
    // Not a session.
    let empty = temp("empty");
    std::fs::create_dir_all(&empty)?;
    let out = aibr().arg("reconstruct").arg(&empty).output()?;
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("is not an aibr session"));

    let dir = temp("bad");
    let options = [
        "--rig",
        "sim:head",
        "--initial",
        "4",
        "--max",
        "4",
        "--grid",
        "16",
    ];
    capture_ok(&options, &dir)?;
    // A new capture into it is refused.
    let out = aibr()
        .arg("capture")
        .args(["--rig", "sim:head", "--initial", "4", "--max", "4"])
        .arg("--out")
        .arg(&dir)
        .output()?;
    assert!(String::from_utf8_lossy(&out.stderr).contains("already holds a session"));

    // A session written before the planner's width power was recorded was planned with
    // width 1: it resumes with that, and is refused with the default.
    let file = dir.join("session.json");
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&file)?)?;
    json["parameters"]
        .as_object_mut()
        .ok_or("no parameters")?
        .remove("width_power")
        .ok_or("width_power not recorded")?;
    std::fs::write(&file, serde_json::to_vec_pretty(&json)?)?;
    let resume = |extra: &[&str]| {
        aibr()
            .arg("capture")
            .args(options)
            .args(extra)
            .arg("--out")
            .arg(&dir)
            .arg("--resume")
            .output()
    };
    let out = resume(&[])?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("width_power 1, not 3"),
        "{err}"
    );
    assert_success(&resume(&["--width-power", "1"])?);
    // Likewise the aim reach: split at the middle (0) before it was recorded.
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&file)?)?;
    json["parameters"]
        .as_object_mut()
        .ok_or("no parameters")?
        .remove("aim_reach")
        .ok_or("aim_reach not recorded")?;
    std::fs::write(&file, serde_json::to_vec_pretty(&json)?)?;
    let out = resume(&["--width-power", "1"])?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("aim_reach 0, not 0.5"),
        "{err}"
    );
    assert_success(&resume(&["--width-power", "1", "--aim-reach", "0"])?);
    // And the faces: this session decided from its initial views whether to serve them first
    // (auto, the default), so it is refused with true; written before that was recorded,
    // when faces were not served first, it resumes with false only.
    let planned = ["--width-power", "1", "--aim-reach", "0"];
    let out = resume(&[&planned[..], &["--faces-first", "true"]].concat())?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("faces_first auto, not true"),
        "{err}"
    );
    let mut json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&file)?)?;
    json["parameters"]
        .as_object_mut()
        .ok_or("no parameters")?
        .remove("faces_first")
        .ok_or("faces_first not recorded")?;
    std::fs::write(&file, serde_json::to_vec_pretty(&json)?)?;
    let out = resume(&planned)?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("faces_first false, not auto"),
        "{err}"
    );
    assert_success(&resume(
        &[&planned[..], &["--faces-first", "false"]].concat(),
    )?);

    // A corrupt view: checksum mismatch, named.
    let view = dir.join("views/0002.png");
    let original = std::fs::read(&view)?;
    let mut corrupt = original.clone();
    let last = corrupt.len() - 20;
    corrupt[last] ^= 0xff;
    std::fs::write(&view, &corrupt)?;
    let out = aibr().arg("reconstruct").arg(&dir).output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("0002.png") && err.contains("checksum"),
        "{err}"
    );
    assert!(!dir.join("model.ply").exists(), "nothing written");
    // A truncated session.json: the line is named.
    std::fs::write(&view, &original)?;
    let json = std::fs::read_to_string(dir.join("session.json"))?;
    std::fs::write(dir.join("session.json"), &json[..json.len() / 2])?;
    let out = aibr().arg("reconstruct").arg(&dir).output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("session.json") && err.contains("line"),
        "{err}"
    );
    // Unknown rigs and scenes.
    let out = aibr()
        .arg("capture")
        .args(["--rig", "usb:cam"])
        .arg("--out")
        .arg(temp("rig"))
        .output()?;
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected sim:SCENE"));
    // A replay rig is eval's, and capture says so rather than call it unknown.
    let out = aibr()
        .arg("capture")
        .args(["--rig", "replay:/no/such/ring"])
        .arg("--out")
        .arg(temp("replay"))
        .output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && err.contains("serves `aibr eval` only")
            && !temp("replay").exists(),
        "{err}"
    );
    let out = aibr()
        .args(["scene", "render", "teapot", "--pan", "0", "-o", "x.png"])
        .output()?;
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown scene"));
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&empty);
    Ok(())
}

#[test]
fn active_capture_options_are_refused_with_uniform_capture_alone() -> TestResult {
    let dir = temp("uniform-options");
    // Each command ends with its folder's option, which the folder follows.
    let capture = &["capture", "--strategy", "uniform", "--max", "4", "--out"][..];
    let eval = &["eval", "--strategy", "uniform", "--work"][..];
    let cases = [
        (capture, ["--initial", "6"]),
        (capture, ["--refine-every", "2"]),
        (capture, ["--grid", "64"]),
        (capture, ["--consistent-below", "1"]),
        (capture, ["--width-power", "2"]),
        (capture, ["--aim-reach", "0"]),
        (capture, ["--faces-first", "true"]),
        (capture, ["--face-served-deg", "2"]),
        (eval, ["--capture-grid", "64"]),
        (eval, ["--width-power", "2"]),
    ];
    for (command, [option, value]) in cases {
        let out = aibr()
            .args(command)
            .arg(&dir)
            .args([option, value])
            .output()?;
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{option} accepted");
        assert!(
            err.contains(&format!("{option} steers active capture")),
            "{err}"
        );
    }
    // Evaluating uniform capture alone at the checkpoints given, nothing takes --initial.
    let out = aibr()
        .args(eval)
        .arg(&dir)
        .args(["--checkpoints", "6", "--max", "6", "--initial", "4"])
        .output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && err.contains(
                "--initial is active capture's initial views and the first checkpoint, and \
                 --strategy evaluates uniform capture only at the --checkpoints given"
            ),
        "{err}"
    );
    assert!(!dir.exists());
    // A uniform budget below the default initial count needs no --initial.
    capture_ok(
        &["--rig", "sim:head", "--strategy", "uniform", "--max", "4"],
        &dir,
    )?;
    assert_eq!(count_views(&dir), 4);
    // Nor does an evaluation of uniform capture alone, measured at its budget (the small
    // evaluation without its --capture-grid, which only active capture takes, nor --initial).
    let work = temp("uniform-eval");
    let out = aibr()
        .args(small_eval_without(&["--capture-grid", "--initial"]))
        .args(["--strategy", "uniform", "--max", "5", "--json", "--work"])
        .arg(&work)
        .output()?;
    assert_success(&out);
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout)?;
    let checkpoints = &summary["results"][0]["checkpoints"];
    assert_eq!(checkpoints[0]["views"], 5, "{summary}");
    assert!(checkpoints[1].is_null(), "{summary}");
    // An --initial given is the first checkpoint as given: above the budget, refused.
    let out = aibr()
        .args(small_eval_without(&["--capture-grid"]))
        .args(["--strategy", "uniform", "--max", "3", "--work"])
        .arg(&work)
        .output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("each must be between 3 and the budget 3"),
        "{err}"
    );
    for d in [dir, work] {
        let _ = std::fs::remove_dir_all(d);
    }
    Ok(())
}

#[test]
fn voxel_coloring_options_are_refused_where_space_carving_reconstructs() -> TestResult {
    // A volume reaching above the cameras (about 0.3 m up): space carving reconstructs it.
    let dir = temp("carved");
    let tall = "--volume=-0.15,-0.15,0,0.15,0.15,3";
    capture_ok(
        &[
            "--rig",
            "sim:head",
            "--strategy",
            "uniform",
            "--max",
            "4",
            tall,
        ],
        &dir,
    )?;
    let reconstruct = |options: &[&str]| aibr().arg("reconstruct").arg(&dir).args(options).output();
    for option in [
        &["--criterion", "classic"][..],
        &["--behind-hull", "off"],
        &["--sample-inset", "0.5"],
        &["--column-test"],
    ] {
        let out = reconstruct(option)?;
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{option:?} accepted");
        assert!(
            err.contains(&format!("{} is for voxel coloring", option[0]))
                && err.contains("view 0: camera centre"),
            "{err}"
        );
        assert!(!dir.join("model.ply").exists());
    }
    let out = reconstruct(&["--grid", "32"])?;
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("space carving:"));
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[test]
fn scene_render_writes_image_depth_and_mask() -> TestResult {
    let dir = temp("scene");
    std::fs::create_dir_all(&dir)?;
    let out = aibr()
        .args(["scene", "render", "mirror", "--pan", "90", "-o"])
        .arg(dir.join("m.png"))
        .arg("--depth")
        .arg(dir.join("m.exr"))
        .arg("--mask")
        .arg(dir.join("mask.png"))
        .output()?;
    assert_success(&out);
    let mask = image::open(dir.join("mask.png"))?.to_luma8();
    assert!(mask.pixels().any(|p| p.0[0] == 255) && mask.pixels().any(|p| p.0[0] == 0));
    // An output named for another format than it would hold is refused before rendering,
    // naming the option, and nothing is written.
    for (flag, name, format) in [
        ("--depth", "d.png", "OpenEXR"),
        ("--mask", "mask.exr", "PNG"),
        ("-o", "m.jpg", "PNG"),
    ] {
        let mut render = aibr();
        render.args(["scene", "render", "mirror", "--pan", "90"]);
        if flag != "-o" {
            render.arg("-o").arg(dir.join("ok.png"));
        }
        let out = render.arg(flag).arg(dir.join(name)).output()?;
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{flag} {name}: {stderr}");
        assert!(
            stderr.contains(flag) && stderr.contains(name) && stderr.contains(format),
            "{stderr}"
        );
        assert!(!dir.join(name).exists() && !dir.join("ok.png").exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// The volume estimated from the initial views' foreground holds the object, snugly.
#[test]
fn volume_estimated_from_the_initial_views() -> TestResult {
    let dir = temp("auto");
    let out = aibr()
        .arg("capture")
        .args([
            "--rig",
            "sim:head",
            "--initial",
            "8",
            "--max",
            "9",
            "--grid",
            "24",
            "--volume",
            "auto",
        ])
        .arg("--out")
        .arg(&dir)
        .output()?;
    assert_success(&out);
    let session = aibr::Session::open(&dir)?;
    let estimated = session.volume()?;
    let truth = aibr::scene::catalogue::head()?.object_bounds();
    for a in 0..3 {
        assert!(
            estimated.min[a] <= truth.min[a] && estimated.max[a] >= truth.max[a],
            "{estimated:?} does not hold {truth:?}"
        );
    }
    let (e, t) = (estimated.extent(), truth.extent());
    assert!(
        e.x * e.y * e.z < 3.0 * t.x * t.y * t.z,
        "{estimated:?} is much larger than {truth:?}"
    );
    // A malformed box is refused before anything is written.
    let bad = temp("badvolume");
    let out = aibr()
        .arg("capture")
        .args(["--volume", "1,2,3"])
        .arg("--out")
        .arg(&bad)
        .output()?;
    assert!(String::from_utf8_lossy(&out.stderr).contains("six numbers"));
    assert!(!bad.exists());
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// A view of another size (with a matching checksum, so only the size is wrong) and a grid
/// too large for memory are refused with errors that name the problem.
#[test]
fn wrong_sized_views_and_huge_grids_are_refused() -> TestResult {
    let dir = temp("sizes");
    capture_ok(
        &[
            "--rig",
            "sim:lambertian",
            "--initial",
            "4",
            "--max",
            "4",
            "--grid",
            "16",
        ],
        &dir,
    )?;

    let out = aibr()
        .arg("reconstruct")
        .arg(&dir)
        .args(["--grid", "100000"])
        .output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("bytes") && err.contains("coarser"),
        "{err}"
    );
    assert!(!dir.join("model.ply").exists());

    // Replace view 1 by a smaller image and record its checksum, as a careless edit would.
    let small = image::RgbImage::new(320, 240);
    let mut bytes = std::io::Cursor::new(Vec::new());
    small.write_to(&mut bytes, image::ImageFormat::Png)?;
    let bytes = bytes.into_inner();
    std::fs::write(dir.join("views/0001.png"), &bytes)?;
    let mut session: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("session.json"))?)?;
    session["views"][1]["image_crc32"] = serde_json::json!(crc32(&bytes));
    std::fs::write(
        dir.join("session.json"),
        serde_json::to_string_pretty(&session)?,
    )?;
    let out = aibr().arg("reconstruct").arg(&dir).output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("0001.png") && err.contains("320x240"),
        "{err}"
    );
    assert!(!dir.join("model.ply").exists());
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// CRC-32 (IEEE), as session.json records it.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// With every arc counted consistent, the capture stops after the initial views.
#[test]
fn capture_stops_when_every_arc_is_consistent() -> TestResult {
    let dir = temp("consistent");
    let out = aibr()
        .arg("capture")
        .args([
            "--rig",
            "sim:lambertian",
            "--initial",
            "4",
            "--max",
            "10",
            "--grid",
            "16",
            "--consistent-below",
            "1e12",
            "--json",
        ])
        .arg("--out")
        .arg(&dir)
        .output()?;
    assert_success(&out);
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout)?;
    assert_eq!(summary["stopped_early"], true);
    assert_eq!(summary["views"].as_array().map(|v| v.len()), Some(4));
    let out = aibr()
        .arg("capture")
        .args(["--consistent-below", "-1"])
        .arg("--out")
        .arg(temp("negative"))
        .output()?;
    assert!(String::from_utf8_lossy(&out.stderr).contains("consistent_below"));
    // A width power, an aim reach, a face tolerance or a scene turn out of its domain is
    // refused, naming it, before a session folder is made.
    for (flag, bad, named) in [
        ("--width-power", "-1", "width_power"),
        ("--width-power", "9", "width_power"),
        ("--width-power", "NaN", "width_power"),
        ("--aim-reach", "-0.5", "aim_reach"),
        ("--aim-reach", "1.5", "aim_reach"),
        ("--faces-first", "maybe", "faces-first"),
        ("--face-served-deg", "0", "face_served_deg"),
        ("--face-served-deg", "12", "face_served_deg"),
        ("--rig", "sim:mirror@x", "scene turn"),
        ("--rig", "sim:mirror@190", "scene turn"),
    ] {
        let folder = temp("bad-option");
        let out = aibr()
            .arg("capture")
            .args([flag, bad])
            .arg("--out")
            .arg(&folder)
            .output()?;
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(named), "{err}");
        assert!(!folder.exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// `aibr eval` of `sim:lambertian` at a size a test can afford (4 initial views, models of
/// 24 and 16 voxels, novel views 40 degrees apart); each test adds its budget and checkpoints.
const SMALL_EVAL: [&str; 11] = [
    "eval",
    "--rig",
    "sim:lambertian",
    "--initial",
    "4",
    "--grid",
    "24",
    "--capture-grid",
    "16",
    "--step-deg",
    "40",
];

/// [`SMALL_EVAL`] without `options`, each with its value.
fn small_eval_without(options: &[&str]) -> Vec<&'static str> {
    let (command, pairs) = SMALL_EVAL.split_at(1);
    let kept = pairs.chunks(2).filter(|pair| !options.contains(&pair[0]));
    command.iter().chain(kept.flatten()).copied().collect()
}

/// The JSON of a successful [`SMALL_EVAL`] with `options`, its sessions in `work`.
fn small_eval_json(
    options: &[&str],
    work: &Path,
) -> Result<serde_json::Value, Box<dyn std::error::Error>> {
    let out = aibr()
        .args(SMALL_EVAL)
        .args(options)
        .args(["--json", "--work"])
        .arg(work)
        .output()?;
    assert_success(&out);
    // Standard error is not a terminal here, so progress comes as log lines (the first at
    // least), each with the time since the start and the rig.
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.lines()
            .any(|l| l.starts_with("[0:") && l.contains("] sim:lambertian: ")),
        "no progress line in {err:?}"
    );
    Ok(serde_json::from_slice(&out.stdout)?)
}

/// `aibr eval` on a small configuration: both strategies, every checkpoint, sane figures.
#[test]
fn eval_compares_strategies_on_ground_truth() -> TestResult {
    let work = temp("eval");
    let budget = ["--max", "6", "--checkpoints", "4,6"];
    let summary = small_eval_json(&budget, &work)?;
    let results = summary["results"].as_array().ok_or("no results")?;
    assert_eq!(results.len(), 2);
    // Active capture says what its initial views decided (faces first by default: `auto`),
    // and the decision follows the contrast; uniform capture plans nothing.
    let active = &results[0];
    assert_eq!(active["strategy"], "active");
    let contrast = active["initial_contrast"]
        .as_f64()
        .ok_or("no initial contrast")?;
    assert!(contrast >= 1.0, "{contrast}");
    assert_eq!(
        active["served_faces_first"].as_bool(),
        Some(contrast >= 2.0),
        "{contrast}"
    );
    assert!(results[1]["served_faces_first"].is_null());
    assert!(results[1]["initial_contrast"].is_null());
    for r in results {
        let cps = r["checkpoints"].as_array().ok_or("no checkpoints")?;
        assert_eq!(
            cps.iter().map(|c| c["views"].as_u64()).collect::<Vec<_>>(),
            vec![Some(4), Some(6)]
        );
        for c in cps {
            let psnr = c["mean_masked_psnr_db"].as_f64().ok_or("no psnr")?;
            assert!(psnr > 8.0 && psnr < 60.0, "{psnr}");
            assert!(c["evaluated_views"].as_u64().is_some_and(|n| n >= 3));
            assert!(
                c["worst_arc_psnr_db"]
                    .as_f64()
                    .is_some_and(|w| w <= psnr + 1e-9)
            );
            // The per-view figures are the ones the mean is made of.
            let novel = c["novel_views"].as_array().ok_or("no novel views")?;
            assert_eq!(Some(novel.len() as u64), c["evaluated_views"].as_u64());
            let values: Vec<f64> = novel
                .iter()
                .filter_map(|v| v["masked_psnr_db"].as_f64())
                .collect();
            assert_eq!(values.len(), novel.len());
            let mean = values.iter().sum::<f64>() / values.len() as f64;
            assert!((mean - psnr).abs() < 1e-9, "{mean} vs {psnr}");
            // And the pooled one is the PSNR of their mean squared error.
            let mse =
                values.iter().map(|p| 10f64.powf(-p / 10.0)).sum::<f64>() / values.len() as f64;
            let pooled = c["pooled_masked_psnr_db"]
                .as_f64()
                .ok_or("no pooled psnr")?;
            assert!((pooled + 10.0 * mse.log10()).abs() < 1e-9, "{pooled}");
            assert!(pooled <= psnr + 1e-9);
            let pans: Vec<f64> = novel.iter().filter_map(|v| v["pan_deg"].as_f64()).collect();
            assert!(pans.windows(2).all(|w| w[0] < w[1]), "{pans:?}");
        }
    }
    // Per checkpoint, both strategies report the same angles neither captured, and their
    // means over exactly those angles.
    let novel_at = |r: &serde_json::Value, i: usize| -> Vec<(f64, f64)> {
        r["checkpoints"][i]["novel_views"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|v| Some((v["pan_deg"].as_f64()?, v["masked_psnr_db"].as_f64()?)))
            .collect()
    };
    for i in 0..2 {
        let (a, u) = (novel_at(&results[0], i), novel_at(&results[1], i));
        let common: Vec<f64> = a
            .iter()
            .filter(|(p, _)| u.iter().any(|(q, _)| q == p))
            .map(|(p, _)| *p)
            .collect();
        assert!(!common.is_empty());
        for (r, views) in [(&results[0], &a), (&results[1], &u)] {
            let k = &r["checkpoints"][i]["common_angles"];
            assert_eq!(k["angles"].as_u64(), Some(common.len() as u64), "{k}");
            let mean = views
                .iter()
                .filter(|(p, _)| common.contains(p))
                .map(|(_, psnr)| psnr)
                .sum::<f64>()
                / common.len() as f64;
            let reported = k["mean_masked_psnr_db"].as_f64().ok_or("no common mean")?;
            assert!((reported - mean).abs() < 1e-9, "{reported} vs {mean}");
        }
    }
    // The same sessions rendered from the true geometry: the views are the same (the capture
    // does not depend on the model), and each set renders better than from its
    // reconstruction (by 1.6 to 2.5 dB when this was written).
    let truth = small_eval_json(&[&budget[..], &["--model", "truth"]].concat(), &work)?;
    assert_eq!(summary["model"], "reconstructed");
    assert_eq!(truth["model"], "truth");
    // Per checkpoint: its views, mean PSNR, and the model's accuracy, completeness and
    // surface voxels.
    let checkpoints = |v: &serde_json::Value| -> Vec<(serde_json::Value, [f64; 4])> {
        v["results"]
            .as_array()
            .into_iter()
            .flatten()
            .flat_map(|r| r["checkpoints"].as_array().into_iter().flatten())
            .map(|c| {
                let f = |x: &serde_json::Value| x.as_f64().unwrap_or(f64::NAN);
                let g = &c["geometry"];
                let figures = [
                    f(&c["mean_masked_psnr_db"]),
                    f(&g["accuracy_voxels"]),
                    f(&g["completeness"]),
                    f(&g["surface_voxels"]),
                ];
                (c["pans_deg"].clone(), figures)
            })
            .collect()
    };
    let (rec, tru) = (checkpoints(&summary), checkpoints(&truth));
    assert_eq!(rec.len(), 4);
    assert_eq!(tru.len(), 4);
    for (
        (rec_pans, [rec_psnr, rec_acc, rec_comp, _]),
        (tru_pans, [tru_psnr, tru_acc, tru_comp, _]),
    ) in rec.iter().zip(&tru)
    {
        assert_eq!(rec_pans, tru_pans);
        assert!(*tru_psnr > rec_psnr + 0.5, "{tru_psnr} vs {rec_psnr}");
        // The scene's own geometry, voxelised, lies on its true surface (voxel centres within
        // a voxel of it) and covers all of it; four or six views reconstruct it worse (0.92
        // voxels / 100% against 1.5-2.1 / 81-91% when this was written).
        assert!(*tru_acc < 1.0 && *tru_comp > 0.99, "{tru_acc} {tru_comp}");
        assert!(
            rec_acc > tru_acc && rec_comp < tru_comp,
            "{rec_acc} {rec_comp}"
        );
    }
    // The same sessions rendered from the reconstruction with its tops refined and walled,
    // and from the views reconstructed with the column test: the same views, and models the
    // option changed.
    for model in ["refined", "column"] {
        let other = small_eval_json(&[&budget[..], &["--model", model]].concat(), &work)?;
        assert_eq!(other["model"], model);
        let figures = checkpoints(&other);
        assert_eq!(rec.len(), figures.len());
        assert!(rec.iter().zip(&figures).all(|(a, b)| a.0 == b.0));
        assert!(
            rec.iter().zip(&figures).any(|(a, b)| a.1[3] != b.1[3]),
            "{model}: {figures:?}"
        );
    }
    // Rendered with a deeper refinement: the same views and models, other renders.
    let search = |json: &serde_json::Value| {
        ["reach_voxels", "refine_steps", "reach_penalty"].map(|k| json[k].as_f64())
    };
    assert_eq!(search(&summary), [Some(4.0), Some(7.0), Some(0.0)]);
    // The refinement's earlier pair of sources, the two nearest: recorded, and the same
    // renders wherever the views are evenly spread (the initial views and uniform capture's;
    // the checkpoints come active first, then uniform).
    assert_eq!(summary["refine_pair"], "across");
    assert_eq!(summary["reflections"], false);
    assert_eq!(summary["occlusion_tolerance_voxels"].as_f64(), Some(2.0));
    // Mirrors rendered as reflections, the ones the model lacks from the visual hull of the
    // rig's masks: recorded, the same views and models, and a matte scene renders within a
    // few hundredths of a decibel as without them.
    let mirrored = small_eval_json(&[&budget[..], &["--reflections", "on"]].concat(), &work)?;
    assert_eq!(mirrored["reflections"], true);
    let figures = checkpoints(&mirrored);
    assert_eq!(rec.len(), figures.len());
    for (a, b) in rec.iter().zip(&figures) {
        assert!(a.0 == b.0 && a.1[1..] == b.1[1..], "{figures:?}");
        assert!((a.1[0] - b.1[0]).abs() < 0.05, "{rec:?} vs {figures:?}");
    }
    // Each checkpoint counts the surface voxels judged for mirrors, in the model and in the
    // hull, and those kept (none without reflections).
    let each = |s: &serde_json::Value| -> Vec<serde_json::Value> {
        s["results"]
            .as_array()
            .into_iter()
            .flatten()
            .flat_map(|r| r["checkpoints"].as_array().cloned().unwrap_or_default())
            .collect()
    };
    assert!(each(&summary).iter().all(|c| c.get("mirrors").is_none()));
    let counted = each(&mirrored);
    assert_eq!(counted.len(), rec.len());
    for c in &counted {
        for part in ["model", "visual_hull"] {
            let t = &c["mirrors"][part];
            let n = |k: &str| t[k].as_u64().ok_or(format!("{part}: no {k} in {c}"));
            let (surface, passed, mirrors) = (n("surface_voxels")?, n("passed")?, n("mirrors")?);
            assert!(
                surface > 0 && passed <= surface && mirrors <= passed,
                "{part}: {t}"
            );
        }
    }
    let nearest = small_eval_json(
        &[&budget[..], &["--refine-pair", "nearest"]].concat(),
        &work,
    )?;
    assert_eq!(nearest["refine_pair"], "nearest");
    let figures = checkpoints(&nearest);
    assert_eq!(rec.len(), figures.len());
    for i in [0, 2, 3] {
        assert_eq!(rec[i], figures[i], "checkpoint {i}");
    }
    let deep = small_eval_json(&[&budget[..], &DEEP_SEARCH].concat(), &work)?;
    assert_eq!(search(&deep), [Some(8.0), Some(12.0), Some(0.3)]);
    let figures = checkpoints(&deep);
    assert_eq!(rec.len(), figures.len());
    assert!(
        rec.iter()
            .zip(&figures)
            .all(|(a, b)| a.0 == b.0 && a.1[1..] == b.1[1..])
    );
    assert!(
        rec.iter().zip(&figures).any(|(a, b)| a.1[0] != b.1[0]),
        "{figures:?}"
    );
    // Its sessions were captured with the default planner: another width power on the same
    // folder is refused, naming the folder and the field, and leaves them as they were.
    let active = work.join("lambertian-active").join("session.json");
    let before = std::fs::read(&active)?;
    let other = aibr()
        .args(SMALL_EVAL)
        .args(budget)
        .args(["--width-power", "2", "--work"])
        .arg(&work)
        .output()?;
    let err = String::from_utf8_lossy(&other.stderr);
    assert!(
        !other.status.success()
            && err.contains("lambertian-active")
            && err.contains("width_power 3, not 2"),
        "{err}"
    );
    assert_eq!(std::fs::read(&active)?, before);
    let out = aibr()
        .args([
            "eval",
            "--initial",
            "3",
            "--max",
            "6",
            "--checkpoints",
            "7",
            "--work",
        ])
        .arg(&work)
        .output()?;
    assert!(String::from_utf8_lossy(&out.stderr).contains("checkpoints"));
    // A strategy given twice (it would be evaluated and reported twice), and a bad count,
    // named as itself rather than as a checkpoint out of range.
    for (options, named) in [
        (
            ["--strategy", "active,uniform,active"],
            "invalid strategies: active is given twice",
        ),
        (
            ["--initial", "1"],
            "invalid initial: at least 3 views are needed to start, not 1",
        ),
    ] {
        let out = aibr()
            .arg("eval")
            .args(options)
            .arg("--work")
            .arg(&work)
            .output()?;
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(named), "{err}");
    }
    // A missing replay folder: its path and the reason, each said once.
    let missing = work.join("no-such-ring");
    let out = aibr()
        .args(["eval", "--rig"])
        .arg(format!("replay:{}", missing.display()))
        .arg("--work")
        .arg(&work)
        .output()?;
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains(&format!("{}", missing.display())),
        "{err}"
    );
    assert_eq!(err.matches("(os error 2)").count(), 1, "{err}");
    let _ = std::fs::remove_dir_all(&work);
    Ok(())
}

/// `aibr eval --turns`: one evaluation per turn of the scene, each in its own folder and
/// recorded as that rig, and the summary made of their figures.
#[test]
fn eval_over_turns_of_the_scene() -> TestResult {
    let work = temp("eval-turns");
    let options = [
        "--max",
        "5",
        "--checkpoints",
        "5",
        "--turns",
        "0,-30",
        "--arc",
        "0:180",
    ];
    let v = small_eval_json(&options, &work)?;
    let turns = v["turns"].as_array().ok_or("no turns")?;
    let (mut leads, mut on_arc_leads) = (Vec::new(), Vec::new());
    for (t, (turn, rig, folder)) in turns.iter().zip([
        (0.0, "sim:lambertian", "turn0/lambertian-active"),
        (-30.0, "sim:lambertian@-30", "turn-30/lambertian@-30-active"),
    ]) {
        assert_eq!(t["turn_deg"].as_f64(), Some(turn));
        assert_eq!(t["rig"].as_str(), Some(rig));
        let session: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(
            work.join(folder).join("session.json"),
        )?)?;
        assert_eq!(session["rig"].as_str(), Some(rig));
        let psnr = |strategy: &str| {
            t["results"]
                .as_array()
                .into_iter()
                .flatten()
                .find(|r| r["strategy"] == strategy)
                .and_then(|r| r["checkpoints"][0]["mean_masked_psnr_db"].as_f64())
        };
        let (a, u) = (
            psnr("active").ok_or("active")?,
            psnr("uniform").ok_or("uniform")?,
        );
        leads.push(a - u);
        // The arc of the object's pans 0 to 180: the novel views whose pan plus the turn lies
        // on it, split from the others, every novel view on one side or the other.
        let mut on_arc_mean = Vec::new();
        for r in t["results"].as_array().ok_or("no results")? {
            let c = &r["checkpoints"][0];
            let arc = &c["arc"];
            let scene_turn = arc["scene_turn_deg"].as_f64().ok_or("no turn")?;
            assert!((scene_turn - turn).abs() < 1e-9, "{scene_turn}");
            let (mut on, mut off, mut sum) = (0, 0, 0.0);
            for view in c["novel_views"].as_array().ok_or("no novel views")? {
                let pan = view["pan_deg"].as_f64().ok_or("pan")? + turn;
                if (0.0..=180.0).contains(&pan) {
                    on += 1;
                    sum += view["masked_psnr_db"].as_f64().ok_or("psnr")?;
                } else {
                    off += 1;
                }
            }
            assert_eq!(arc["on_arc"]["angles"].as_u64(), Some(on));
            assert_eq!(arc["off_arc"]["angles"].as_u64(), Some(off));
            let mean = arc["on_arc"]["mean_masked_psnr_db"]
                .as_f64()
                .ok_or("on arc")?;
            assert!((mean - sum / on as f64).abs() < 1e-9);
            on_arc_mean.push(mean);
        }
        on_arc_leads.push(on_arc_mean[0] - on_arc_mean[1]);
    }
    let summary = &v["active_minus_uniform"][0];
    assert_eq!(summary["views"].as_u64(), Some(5));
    // A summarised lead's figures, turn by turn.
    let by_turn = |measure: &str| -> Result<Vec<f64>, String> {
        Ok(summary[measure]["by_turn"]
            .as_array()
            .ok_or(format!("no {measure}"))?
            .iter()
            .filter_map(|x| x.as_f64())
            .collect())
    };
    assert_eq!(by_turn("mean_masked_psnr_db")?, leads);
    let over = &summary["mean_masked_psnr_db"];
    let mean = over["mean"].as_f64().ok_or("no mean")?;
    assert!((mean - (leads[0] + leads[1]) / 2.0).abs() < 1e-12);
    assert_eq!(over["min"].as_f64(), Some(leads[0].min(leads[1])));
    assert_eq!(over["max"].as_f64(), Some(leads[0].max(leads[1])));
    // Two turns: the standard error of their mean is half their difference.
    let error = over["standard_error"].as_f64().ok_or("no standard error")?;
    assert!((error - (leads[0] - leads[1]).abs() / 2.0).abs() < 1e-12);
    let ahead = leads.iter().filter(|&&x| x > 0.0).count();
    assert_eq!(over["turns_ahead"].as_u64(), Some(ahead as u64));
    // The leads on the arc, made of the per-turn figures (active listed first).
    assert_eq!(by_turn("arc_inside_mean_masked_psnr_db")?, on_arc_leads);
    assert!(summary["common_angles_mean_masked_psnr_db"]["mean"].is_f64());
    // An arc that is no arc, or no numbers, is refused before anything runs.
    for arc in ["10:370", "a:b", "10"] {
        let refused = temp("eval-arc-refused");
        let out = aibr()
            .args(["eval", "--arc", arc, "--work"])
            .arg(&refused)
            .output()?;
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains("--arc"), "{err}");
        assert!(!refused.exists());
    }
    // Turns need an unturned synthetic rig, and every turn is checked before any runs.
    for (rig, turns) in [("sim:lambertian@5", "0,10"), ("sim:lambertian", "0,400")] {
        let refused = temp("eval-turns-refused");
        let out = aibr()
            .args(["eval", "--rig", rig, "--turns", turns, "--work"])
            .arg(&refused)
            .output()?;
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains("--turns"), "{err}");
        assert!(!refused.exists());
    }
    let _ = std::fs::remove_dir_all(&work);
    Ok(())
}

#[test]
fn eval_replays_a_real_ring() -> TestResult {
    let Some(data) = aibr_testdata::dataset("middlebury-templeRing") else {
        return Ok(());
    };
    let work = temp("eval-replay");
    let rig = format!("replay:{}", data.display());
    let out = aibr()
        .args([
            "eval",
            "--rig",
            &rig,
            "--initial",
            "4",
            "--max",
            "8",
            "--checkpoints",
            "4,8",
        ])
        .args(["--grid", "32", "--capture-grid", "24", "--json", "--work"])
        .arg(&work)
        .output()?;
    assert_success(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout)?;
    let results = v["results"].as_array().ok_or("results")?;
    assert_eq!(results.len(), 2);
    let replay = aibr::ReplayRig::open(&data)?;
    let recorded: Vec<f64> = replay.views().iter().map(|v| v.pan.degrees()).collect();
    for r in results {
        for c in r["checkpoints"].as_array().ok_or("checkpoints")? {
            let n = c["views"].as_u64().ok_or("views")? as usize;
            // Every view not captured is measured against its recorded image.
            assert_eq!(
                c["evaluated_views"].as_u64(),
                Some((recorded.len() - n) as u64)
            );
            let psnr = c["mean_masked_psnr_db"].as_f64().ok_or("psnr")?;
            assert!(psnr.is_finite() && psnr > 10.0, "{psnr}");
            // A real ring knows no true surface to score the model against.
            assert!(c["geometry"].is_null(), "{}", c["geometry"]);
            let pans = c["pans_deg"].as_array().ok_or("pans")?;
            for p in pans {
                let p = p.as_f64().ok_or("pan")?;
                assert!(
                    recorded.iter().any(|r| (r - p).abs() < 1e-6),
                    "{p} is not a recorded view"
                );
            }
        }
    }
    let refused = |args: &[&str], work: &Path, why: &str| -> TestResult {
        let out = aibr()
            .args(["eval", "--rig", &rig])
            .args(args)
            .arg("--work")
            .arg(work)
            .output()?;
        assert!(!out.status.success());
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(why),
            "{}",
            text(&out)
        );
        Ok(())
    };
    // A budget that holds nothing out is refused.
    refused(&["--max", "60"], &work, "must leave some out")?;
    // A real ring has no true geometry to render from: refused before anything is captured.
    let untouched = temp("eval-replay-truth");
    refused(
        &["--model", "truth"],
        &untouched,
        "does not know its true geometry",
    )?;
    assert!(!untouched.exists());
    let _ = std::fs::remove_dir_all(&work);
    Ok(())
}
