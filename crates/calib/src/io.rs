//! Camera calibration files: OpenCV FileStorage YAML and JSON.
//!
//! The YAML is what OpenCV's `FileStorage` writes and its calibration sample reads:
//! `image_width`, `image_height`, `camera_matrix` and `distortion_coefficients` as
//! `!!opencv-matrix` (`rows`, `cols`, `dt`, `data`), plus `avg_reprojection_error` when
//! known. Other keys are ignored on reading. The JSON has the same content with plain
//! names (`fx`, `fy`, `cx`, `cy`, `skew`, `distortion` in k1 k2 p1 p2 k3 order); a report
//! of `aibr calibrate intrinsics --json` is also a valid JSON camera file.
//!
//! [`CameraFile::read`] is the reader; writing is left to the caller's I/O edge (the
//! command line writes atomically with `aibr::write_atomic`), from [`CameraFile::to_text`].

use std::collections::HashMap;
use std::path::Path;

use aibr_camera::{Distortion, ImageSize, Intrinsics};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// A calibrated camera as stored in a file.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraFile {
    /// The image size the calibration holds for.
    pub image_size: ImageSize,
    /// Intrinsics.
    pub intrinsics: Intrinsics,
    /// Lens distortion.
    pub distortion: Distortion,
    /// RMS reprojection error of the calibration, pixels, when known.
    pub rms: Option<f64>,
}

/// The JSON form of [`CameraFile`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraJson {
    /// Image width, pixels.
    pub image_width: u32,
    /// Image height, pixels.
    pub image_height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Skew, pixels.
    #[serde(default)]
    pub skew: f64,
    /// k1 k2 p1 p2 k3 (4 values: k3 = 0).
    pub distortion: Vec<f64>,
    /// RMS reprojection error, pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rms: Option<f64>,
}

impl CameraFile {
    /// The JSON form.
    pub fn to_json(&self) -> CameraJson {
        let i = self.intrinsics;
        CameraJson {
            image_width: self.image_size.width,
            image_height: self.image_size.height,
            fx: i.fx,
            fy: i.fy,
            cx: i.cx,
            cy: i.cy,
            skew: i.skew,
            distortion: self.distortion.to_array().to_vec(),
            rms: self.rms,
        }
    }

    /// From the JSON form, validated.
    pub fn from_json(j: &CameraJson) -> Result<Self> {
        let intrinsics = Intrinsics {
            fx: j.fx,
            fy: j.fy,
            cx: j.cx,
            cy: j.cy,
            skew: j.skew,
        };
        intrinsics.validate()?;
        let image_size =
            checked_size(j.image_width as f64, j.image_height as f64).ok_or_else(|| {
                Error::InvalidParameter {
                    name: "image size",
                    value: format!("{}x{}", j.image_width, j.image_height),
                    reason: "must be positive",
                }
            })?;
        Ok(CameraFile {
            image_size,
            intrinsics,
            distortion: Distortion::from_opencv(&j.distortion)?,
            rms: j.rms,
        })
    }

    /// OpenCV FileStorage YAML.
    pub fn to_opencv_yaml(&self) -> String {
        let i = self.intrinsics;
        let k = [i.fx, i.skew, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0];
        let mut out = String::from("%YAML:1.0\n---\n");
        out += &format!(
            "image_width: {}\nimage_height: {}\n",
            self.image_size.width, self.image_size.height
        );
        out += &matrix_yaml("camera_matrix", 3, 3, &k);
        out += &matrix_yaml("distortion_coefficients", 5, 1, &self.distortion.to_array());
        if let Some(rms) = self.rms {
            out += &format!("avg_reprojection_error: {}\n", opencv_float(rms));
        }
        out
    }

    /// Parses OpenCV FileStorage YAML; `source_name` names the text in errors.
    pub fn parse_opencv_yaml(text: &str, source_name: &str) -> Result<Self> {
        let doc = parse_yaml(text, source_name)?;
        let err = |line: usize, message: String| Error::Parse {
            source_name: source_name.to_string(),
            line,
            message,
        };
        let scalar = |key: &str| -> Result<(f64, usize)> {
            match doc.get(key) {
                Some((Value::Scalar(s), line)) => s
                    .parse::<f64>()
                    .map(|v| (v, *line))
                    .map_err(|_| err(*line, format!("{key}: {s:?} is not a number"))),
                Some((Value::Matrix { .. }, line)) => Err(err(
                    *line,
                    format!("{key}: expected a number, found a matrix"),
                )),
                None => Err(err(0, format!("no {key}"))),
            }
        };
        let matrix = |key: &str| -> Result<(usize, usize, Vec<f64>, usize)> {
            match doc.get(key) {
                Some((Value::Matrix { rows, cols, data }, line)) => {
                    Ok((*rows, *cols, data.clone(), *line))
                }
                Some((Value::Scalar(_), line)) => {
                    Err(err(*line, format!("{key}: expected an !!opencv-matrix")))
                }
                None => Err(err(0, format!("no {key}"))),
            }
        };
        let (w, wl) = scalar("image_width")?;
        let (h, _) = scalar("image_height")?;
        let image_size = checked_size(w, h).ok_or_else(|| {
            err(
                wl,
                format!("image size {w}x{h} is not a positive whole number of pixels"),
            )
        })?;
        let (rows, cols, k, kl) = matrix("camera_matrix")?;
        if rows != 3 || cols != 3 {
            return Err(err(
                kl,
                format!("camera_matrix is {rows}x{cols}, expected 3x3"),
            ));
        }
        if k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
            return Err(err(
                kl,
                "camera_matrix is not of the form [fx s cx; 0 fy cy; 0 0 1]".into(),
            ));
        }
        let intrinsics = Intrinsics {
            fx: k[0],
            fy: k[4],
            cx: k[2],
            cy: k[5],
            skew: k[1],
        };
        intrinsics
            .validate()
            .map_err(|e| err(kl, format!("camera_matrix: {e}")))?;
        let (rows, cols, d, dl) = matrix("distortion_coefficients")?;
        if rows != 1 && cols != 1 {
            return Err(err(
                dl,
                format!("distortion_coefficients is {rows}x{cols}, expected a vector"),
            ));
        }
        // Models beyond k1 k2 p1 p2 k3 are accepted only when their extra terms are zero.
        let (base, extra) = d.split_at(d.len().min(5));
        if extra.iter().any(|&v| v != 0.0) {
            return Err(err(
                dl,
                format!(
                    "{} distortion coefficients with non-zero rational or thin-prism terms: only k1 k2 p1 p2 k3 are supported",
                    d.len()
                ),
            ));
        }
        let distortion = Distortion::from_opencv(base)
            .map_err(|e| err(dl, format!("distortion_coefficients: {e}")))?;
        let rms = match doc.get("avg_reprojection_error") {
            Some(_) => Some(scalar("avg_reprojection_error")?.0),
            None => None,
        };
        Ok(CameraFile {
            image_size,
            intrinsics,
            distortion,
            rms,
        })
    }

    /// Reads a camera file: OpenCV YAML for `.yml` / `.yaml`, JSON for `.json`.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let name = path.display().to_string();
        match Format::of(path)? {
            Format::Yaml => Self::parse_opencv_yaml(&text, &name),
            Format::Json => {
                let j: CameraJson = serde_json::from_str(&text).map_err(|e| Error::Parse {
                    source_name: name.clone(),
                    line: e.line(),
                    message: e.to_string(),
                })?;
                Self::from_json(&j).map_err(|e| Error::Parse {
                    source_name: name,
                    line: 0,
                    message: e.to_string(),
                })
            }
        }
    }

    /// The file's text in `format` (for a writer at the caller's I/O edge; pick the format
    /// from the file name with [`Format::of`]).
    pub fn to_text(&self, format: Format) -> Result<String> {
        Ok(match format {
            Format::Yaml => self.to_opencv_yaml(),
            Format::Json => {
                serde_json::to_string_pretty(&self.to_json()).map_err(|e| Error::Parse {
                    source_name: "camera JSON".into(),
                    line: 0,
                    message: e.to_string(),
                })? + "\n"
            }
        })
    }
}

/// A file's calibration format, from its extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// OpenCV FileStorage YAML (`.yml`, `.yaml`).
    Yaml,
    /// JSON (`.json`).
    Json,
}

impl Format {
    /// The format `path`'s extension names.
    pub fn of(path: &Path) -> Result<Format> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("yml" | "yaml") => Ok(Format::Yaml),
            Some("json") => Ok(Format::Json),
            _ => Err(Error::InvalidParameter {
                name: "calibration file",
                value: path.display().to_string(),
                reason: "the extension must be .yml, .yaml or .json",
            }),
        }
    }
}

fn checked_size(w: f64, h: f64) -> Option<ImageSize> {
    let ok = |v: f64| v >= 1.0 && v <= u32::MAX as f64 && v.fract() == 0.0;
    (ok(w) && ok(h)).then(|| ImageSize::new(w as u32, h as u32))
}

/// A float as OpenCV writes it: 17 significant digits, a signed two-digit exponent.
fn opencv_float(v: f64) -> String {
    if v == 0.0 {
        return "0.".into();
    }
    let s = format!("{v:.16e}");
    match s.split_once('e') {
        Some((m, e)) => {
            let e: i32 = e.parse().unwrap_or(0);
            format!("{m}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
        }
        None => s,
    }
}

fn matrix_yaml(name: &str, rows: usize, cols: usize, data: &[f64]) -> String {
    let values: Vec<String> = data.iter().map(|&v| opencv_float(v)).collect();
    let lines: Vec<String> = values.chunks(3).map(|c| c.join(", ")).collect();
    format!(
        "{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n",
        lines.join(",\n       ")
    )
}

/// A top-level value of the YAML subset OpenCV writes.
#[derive(Debug, Clone, PartialEq)]
enum Value {
    Scalar(String),
    Matrix {
        rows: usize,
        cols: usize,
        data: Vec<f64>,
    },
}

/// Top-level keys with their values and 1-based lines. Nested mappings other than
/// `!!opencv-matrix` are skipped.
fn parse_yaml(text: &str, source_name: &str) -> Result<HashMap<String, (Value, usize)>> {
    let err = |line: usize, message: String| Error::Parse {
        source_name: source_name.to_string(),
        line,
        message,
    };
    let lines: Vec<&str> = text.lines().collect();
    let mut out = HashMap::new();
    let mut i = 0;
    let first = lines.iter().position(|l| !l.trim().is_empty());
    match first.map(|f| lines[f].trim()) {
        Some(l) if l.starts_with("%YAML") => {}
        _ => {
            return Err(err(
                first.map_or(1, |f| f + 1),
                "not OpenCV YAML: the file must begin with %YAML:1.0".into(),
            ));
        }
    }
    while i < lines.len() {
        let raw = lines[i];
        let line_no = i + 1;
        i += 1;
        let line = strip_comment(raw);
        let t = line.trim();
        if t.is_empty() || t.starts_with('%') || t == "---" || t == "..." {
            continue;
        }
        if line.starts_with([' ', '\t']) {
            continue; // inside a mapping we do not read
        }
        let Some((key, rest)) = t.split_once(':') else {
            return Err(err(line_no, format!("expected `key: value`, found {t:?}")));
        };
        let (key, rest) = (key.trim().to_string(), rest.trim());
        if rest == "!!opencv-matrix" {
            let mut fields: HashMap<String, String> = HashMap::new();
            while i < lines.len()
                && (lines[i].starts_with([' ', '\t']) || lines[i].trim().is_empty())
            {
                let l = strip_comment(lines[i]).trim().to_string();
                i += 1;
                if l.is_empty() {
                    continue;
                }
                let Some((k, v)) = l.split_once(':') else {
                    return Err(err(
                        i,
                        format!("{key}: expected `field: value`, found {l:?}"),
                    ));
                };
                let mut v = v.trim().to_string();
                if k.trim() == "data" && v.starts_with('[') {
                    while !v.contains(']') {
                        let Some(next) = lines.get(i) else {
                            return Err(err(i, format!("{key}: data has no closing ]")));
                        };
                        v.push(' ');
                        v.push_str(strip_comment(next).trim());
                        i += 1;
                    }
                }
                fields.insert(k.trim().to_string(), v);
            }
            let int = |f: &str| -> Result<usize> {
                fields
                    .get(f)
                    .ok_or_else(|| err(line_no, format!("{key}: no {f}")))?
                    .parse()
                    .map_err(|_| err(line_no, format!("{key}: {f} is not a count")))
            };
            let (rows, cols) = (int("rows")?, int("cols")?);
            let data = fields
                .get("data")
                .ok_or_else(|| err(line_no, format!("{key}: no data")))?;
            let inner = data
                .trim()
                .strip_prefix('[')
                .and_then(|d| d.trim_end().strip_suffix(']'))
                .ok_or_else(|| err(line_no, format!("{key}: data must be a [ ... ] list")))?;
            let data = inner
                .split(',')
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(|s| {
                    s.parse::<f64>()
                        .map_err(|_| err(line_no, format!("{key}: {s:?} is not a number")))
                })
                .collect::<Result<Vec<f64>>>()?;
            if rows.checked_mul(cols) != Some(data.len()) {
                return Err(err(
                    line_no,
                    format!(
                        "{key}: {rows}x{cols} needs {} values, found {}",
                        rows.saturating_mul(cols),
                        data.len()
                    ),
                ));
            }
            out.insert(key, (Value::Matrix { rows, cols, data }, line_no));
        } else {
            out.insert(
                key,
                (Value::Scalar(rest.trim_matches('"').to_string()), line_no),
            );
        }
    }
    Ok(out)
}

fn strip_comment(line: &str) -> &str {
    match line.find('#') {
        Some(p) => &line[..p],
        None => line,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sample() -> CameraFile {
        CameraFile {
            image_size: ImageSize::new(640, 480),
            intrinsics: Intrinsics {
                fx: 532.8268274390841,
                fy: 532.9456287470435,
                cx: 342.4871580606238,
                cy: 233.85625868229153,
                skew: 0.0,
            },
            distortion: Distortion {
                k1: -0.2808800492219063,
                k2: 0.02516694059260832,
                p1: 0.0012165904406115596,
                p2: -0.00013545999436567172,
                k3: 0.16345546036671268,
            },
            rms: Some(0.19543209386763255),
        }
    }

    #[test]
    fn reads_opencv_sample_output() -> Result<()> {
        // The first lines of OpenCV's calibration sample output (left_intrinsics.yml).
        let text = "%YAML:1.0\n---\nnframes: 13\nimage_width: 640\nimage_height: 480\nsquare_size: 2.5000000372529030e-02\nflags: 2\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 5.3591573396163199e+02, 0., 3.4228315473308373e+02, 0.,\n       5.3591573396163199e+02, 2.3557082909788173e+02, 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n   data: [ -2.6637260909660682e-01, -3.8588898922304653e-02,\n       1.7831947042852964e-03, -2.8122100441115472e-04,\n       2.3839153080878486e-01 ]\navg_reprojection_error: 3.9259098975581364e-01\n";
        let c = CameraFile::parse_opencv_yaml(text, "left_intrinsics.yml")?;
        assert_eq!(c.image_size, ImageSize::new(640, 480));
        assert_eq!(
            c.intrinsics.fx,
            "5.3591573396163199e+02".parse::<f64>().unwrap_or(0.0)
        );
        assert_eq!(
            c.intrinsics.cy,
            "2.3557082909788173e+02".parse::<f64>().unwrap_or(0.0)
        );
        assert_eq!(
            c.distortion.k3,
            "2.3839153080878486e-01".parse::<f64>().unwrap_or(0.0)
        );
        assert_eq!(c.rms, "3.9259098975581364e-01".parse::<f64>().ok());
        Ok(())
    }

    #[test]
    fn yaml_and_json_round_trip_exactly() -> Result<()> {
        let c = sample();
        assert_eq!(
            CameraFile::parse_opencv_yaml(&c.to_opencv_yaml(), "mem")?,
            c
        );
        let j = serde_json::to_string(&c.to_json()).unwrap_or_default();
        let back: CameraJson = serde_json::from_str(&j).unwrap_or_else(|_| c.to_json());
        assert_eq!(CameraFile::from_json(&back)?, c);
        Ok(())
    }

    #[test]
    fn errors_name_the_line() {
        let good = sample().to_opencv_yaml();
        let cases = [
            (good.replace("rows: 3", "rows: 2"), "needs 6 values"),
            (
                good.replace("image_width: 640", "image_width: wide"),
                "not a number",
            ),
            (good.replace("%YAML:1.0", "hello"), "must begin with %YAML"),
            (good.replace("data: [ 5.3", "data: [ x5.3"), "not a number"),
            (
                good.replace("rows: 5\n   cols: 1", "rows: 8\n   cols: 1")
                    .replace(
                        "1.6345546036671268e-01 ]",
                        "1.6345546036671268e-01, 0., 0., 1. ]",
                    ),
                "thin-prism",
            ),
            (
                good.lines()
                    .filter(|l| !l.starts_with("image_height"))
                    .collect::<Vec<_>>()
                    .join("\n"),
                "no image_height",
            ),
        ];
        for (text, expected) in cases {
            match CameraFile::parse_opencv_yaml(&text, "cam.yml") {
                Err(e) => {
                    let m = e.to_string();
                    assert!(m.starts_with("cam.yml:") && m.contains(expected), "{m}");
                }
                Ok(c) => panic!("accepted {c:?} for {expected}"),
            }
        }
        match CameraFile::parse_opencv_yaml(
            &good.replace("image_width: 640", "image_width: wide"),
            "cam.yml",
        ) {
            Err(Error::Parse { line, .. }) => assert_eq!(line, 3),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn files_round_trip_and_the_extension_names_the_format() -> Result<()> {
        let dir = std::env::temp_dir().join(format!("aibr-calib-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(|source| Error::Io {
            path: dir.clone(),
            source,
        })?;
        for name in ["cam.yml", "cam.json"] {
            let path = dir.join(name);
            let text = sample().to_text(Format::of(&path)?)?;
            std::fs::write(&path, text).map_err(|source| Error::Io {
                path: path.clone(),
                source,
            })?;
            assert_eq!(CameraFile::read(&path)?, sample());
        }
        assert!(matches!(
            Format::of(&dir.join("cam.txt")),
            Err(Error::InvalidParameter { .. })
        ));
        assert!(matches!(
            CameraFile::read(&dir.join("missing/cam.yml")),
            Err(Error::Io { .. })
        ));
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    }

    proptest! {
        #[test]
        fn yaml_round_trips(fx in 1.0f64..5000.0, fy in 1.0f64..5000.0, cx in -100.0f64..2000.0, cy in -100.0f64..2000.0,
                            k in proptest::array::uniform5(-1.0f64..1.0), w in 1u32..10000, h in 1u32..10000) {
            let c = CameraFile {
                image_size: ImageSize::new(w, h),
                intrinsics: Intrinsics::new(fx, fy, cx, cy),
                distortion: Distortion { k1: k[0], k2: k[1], p1: k[2], p2: k[3], k3: k[4] },
                rms: None,
            };
            prop_assert_eq!(CameraFile::parse_opencv_yaml(&c.to_opencv_yaml(), "mem").ok(), Some(c));
        }

        #[test]
        fn yaml_parser_never_panics(s in "(%YAML:1.0\n)?([a-z_]{1,8}: (!!opencv-matrix|[0-9.e+-]{0,6})\n(   [a-z]{1,4}: [\\[\\]0-9., ]{0,12}\n){0,4}){0,4}") {
            let _ = CameraFile::parse_opencv_yaml(&s, "fuzz");
        }
    }
}
