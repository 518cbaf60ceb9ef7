//! `aibr ptu` and `aibr capture --turntable ptu:PATH` against `aibr ptu emulate`, over a real
//! pseudo-terminal.

mod common;
use common::*;

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Output, Stdio};

/// An emulator process, stopped when dropped.
struct Emulated {
    child: Child,
    path: String,
}

impl Drop for Emulated {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn emulate() -> Result<Emulated, Box<dyn std::error::Error>> {
    let mut child = aibr()
        .args(["ptu", "emulate", "--speedup", "20"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()?;
    let stdout = child.stdout.take().ok_or("no stdout")?;
    let mut line = String::new();
    BufReader::new(stdout).read_line(&mut line)?;
    let path = line.trim().to_owned();
    assert!(path.starts_with("/dev/"), "emulate printed {line:?}");
    Ok(Emulated { child, path })
}

fn ptu(unit: &Emulated, args: &[&str]) -> Result<Output, Box<dyn std::error::Error>> {
    let out = aibr()
        .args(["ptu", "--port", &unit.path])
        .args(args)
        .output()?;
    assert!(
        out.status.success(),
        "aibr ptu {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Ok(out)
}

fn json(out: &Output) -> Result<serde_json::Value, Box<dyn std::error::Error>> {
    Ok(serde_json::from_slice(&out.stdout)?)
}

#[test]
fn info_move_limits_home_halt() -> TestResult {
    let unit = emulate()?;
    let info = json(&ptu(&unit, &["info", "--json"])?)?;
    assert_eq!(info["pan"]["resolution_arcsec"], 185.1428);
    assert_eq!(info["pan"]["min_steps"], -3090);
    assert_eq!(info["pan"]["max_steps"], 3090);
    assert_eq!(info["limits_enabled"], true);
    assert_eq!(info["echo_was_on"], true);
    assert_eq!(info["pan_steps"], 0);

    let at = json(&ptu(&unit, &["move", "30", "--json"])?)?;
    assert_eq!(
        at["pan_steps"],
        (30.0 * 3600.0 / 185.1428_f64).round() as i64
    );
    let at = json(&ptu(&unit, &["move", "-10", "--relative", "--json"])?)?;
    assert_eq!(
        at["pan_steps"],
        (30.0 * 3600.0 / 185.1428_f64).round() as i64
            - (10.0 * 3600.0 / 185.1428_f64).round() as i64
    );

    // 160 degrees is beyond the soft limit (158.9): refused with the limit, then allowed.
    let refused = aibr()
        .args(["ptu", "--port", &unit.path, "move", "160"])
        .output()?;
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.contains("move to 160 deg") && err.contains("Maximum allowable Pan position is 3090"),
        "{err}"
    );
    assert!(String::from_utf8_lossy(&ptu(&unit, &["limits", "off"])?.stdout).contains("off"));
    let at = json(&ptu(&unit, &["move", "160", "--json"])?)?;
    assert_eq!(
        at["pan_steps"],
        (160.0 * 3600.0 / 185.1428_f64).round() as i64
    );
    ptu(&unit, &["limits", "on"])?;

    let home = json(&ptu(&unit, &["home", "--json"])?)?;
    assert_eq!(home["pan_steps"], 0);
    let text = String::from_utf8_lossy(&ptu(&unit, &["halt"])?.stdout).into_owned();
    assert!(text.contains("pan at 0.0000 deg (0 steps)"), "{text}");
    Ok(())
}

#[test]
fn capture_turns_the_emulated_ptu() -> TestResult {
    let unit = emulate()?;
    let dir = temp("ptu");
    let turntable = format!("ptu:{}", unit.path);
    let out = aibr()
        .args([
            "capture",
            "--turntable",
            &turntable,
            "--camera",
            "sim:lambertian",
        ])
        .args([
            "--initial",
            "4",
            "--max",
            "6",
            "--grid",
            "24",
            "--json",
            "--out",
        ])
        .arg(&dir)
        .output()?;
    assert_success(&out);
    let report = json(&out)?;
    assert_eq!(report["rig"], format!("{turntable}+sim:lambertian"));
    let views = report["views"].as_array().ok_or("no views")?;
    assert_eq!(views.len(), 6);
    let step = 185.1428 / 3600.0;
    for v in views {
        let deg = v["pan_deg"].as_f64().ok_or("pan")?;
        // Every angle is one the unit reached: a whole number of its steps, inside its limits.
        assert!(((deg / step) - (deg / step).round()).abs() < 1e-6, "{deg}");
        assert!(deg.abs() <= 3090.0 * step + 1e-9, "{deg}");
    }
    // The unit ends where the last view was taken.
    let info = json(&ptu(&unit, &["info", "--json"])?)?;
    let last = views[5]["pan_deg"].as_f64().ok_or("pan")?;
    assert!((info["pan_deg"].as_f64().ok_or("pan")? - last).abs() < 1e-9);
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[test]
fn bad_ports_and_specs_are_named() -> TestResult {
    let out = aibr()
        .args(["ptu", "--port", "/dev/aibr-no-such-port", "info"])
        .output()?;
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/dev/aibr-no-such-port"));

    let out = aibr().args(["ptu", "info"]).output()?;
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--port"));

    let out = aibr()
        .args([
            "capture",
            "--turntable",
            "usb:0",
            "--camera",
            "sim:mirror",
            "--out",
            "/tmp/aibr-unused",
        ])
        .output()?;
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected ptu:PATH"));

    let out = aibr()
        .args([
            "capture",
            "--turntable",
            "ptu:/dev/null",
            "--out",
            "/tmp/aibr-unused",
        ])
        .output()?;
    assert!(
        !out.status.success(),
        "--turntable without --camera must be refused"
    );
    assert!(!std::path::Path::new("/tmp/aibr-unused").exists());
    Ok(())
}

/// Options of a real rig are refused where nothing would use them, rather than ignored: a
/// calibration given with a synthetic camera would not be the one the session records.
#[test]
fn real_rig_options_are_refused_where_nothing_uses_them() -> TestResult {
    let out_dir = temp("unused-options");
    let refused = |options: &[&str]| -> Result<String, std::io::Error> {
        let out = aibr()
            .args(["capture", "--max", "12", "--out"])
            .arg(&out_dir)
            .args(options)
            .output()?;
        assert!(!out.status.success(), "{options:?} accepted");
        Ok(String::from_utf8_lossy(&out.stderr).into_owned())
    };
    // Without a real turntable and camera: the synthetic rig.
    for option in [
        ["--calibration", "rig.json"],
        ["--average", "4"],
        ["--exposure", "auto"],
        ["--white-balance", "5000"],
        ["--gain", "auto"],
    ] {
        let err = refused(&option)?;
        assert!(err.contains("--camera"), "{option:?}: {err}");
    }
    assert!(refused(&["--baud", "19200"])?.contains("--turntable"));
    // With a synthetic camera on a real turntable (refused before the port is opened).
    for [option, value] in [
        ["--calibration", "rig.json"],
        ["--average", "4"],
        ["--exposure", "auto"],
        ["--white-balance", "lock"],
        ["--gain", "lock"],
    ] {
        let err = refused(&[
            "--turntable",
            "ptu:/dev/aibr-no-such-port",
            "--camera",
            "sim:mirror",
            option,
            value,
        ])?;
        assert!(err.contains(&format!("{option} is for a webcam")), "{err}");
    }
    assert!(!out_dir.exists());
    Ok(())
}

#[test]
fn webcams_need_a_calibration_and_name_the_device() -> TestResult {
    let dir = temp("v4l");
    std::fs::create_dir_all(&dir)?;
    // A webcam capture (the turntable is never reached), with a calibration file or without.
    let webcam_capture = |calibration: Option<&PathBuf>| {
        let mut command = aibr();
        command.args([
            "capture",
            "--turntable",
            "ptu:/dev/null",
            "--camera",
            "v4l:/dev/video99",
        ]);
        if let Some(c) = calibration {
            command.arg("--calibration").arg(c);
        }
        command.arg("--out").arg(dir.join("s")).output()
    };
    let out = webcam_capture(None)?;
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    if cfg!(feature = "v4l") {
        assert!(err.contains("--calibration"), "{err}");
    } else {
        assert!(err.contains("--features v4l"), "{err}");
    }

    // A calibration in session.json's form, taken from a synthetic session.
    let session = dir.join("sim");
    let ok = aibr()
        .args([
            "capture",
            "--rig",
            "sim:lambertian",
            "--initial",
            "3",
            "--max",
            "3",
            "--grid",
            "16",
            "--out",
        ])
        .arg(&session)
        .stdout(Stdio::null())
        .status()?;
    assert!(ok.success());
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(session.join("session.json"))?)?;
    let calibration = dir.join("calibration.json");
    std::fs::write(&calibration, serde_json::to_string(&file["calibration"])?)?;
    let out = webcam_capture(Some(&calibration))?;
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    if cfg!(feature = "v4l") {
        assert!(err.contains("/dev/video99: no such video device"), "{err}");
    } else {
        assert!(err.contains("--features v4l"), "{err}");
    }
    assert!(
        !dir.join("s").exists(),
        "nothing is created when the camera fails"
    );

    // A calibration file that is not one is named.
    std::fs::write(&calibration, "{\"intrinsics\": 3}")?;
    let out = webcam_capture(Some(&calibration))?;
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a calibration record"));

    let out = aibr().args(["v4l", "list"]).output()?;
    if cfg!(feature = "v4l") {
        assert_success(&out);
    } else {
        assert!(!out.status.success());
        assert!(String::from_utf8_lossy(&out.stderr).contains("--features v4l"));
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}
