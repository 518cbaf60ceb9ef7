//! Readers of dataset camera files: Middlebury `*_par.txt` / `*_ang.txt` and plain files of
//! 3x4 projection matrices.
//!
//! Each format has a pure parser over text (`parse_*`, which takes a name for its error
//! messages) and a reader of a file path (`read_*`). Every error names the file and the
//! 1-based line.

use std::path::Path;

use nalgebra::{Isometry3, Matrix3, Matrix3x4, Translation3, UnitQuaternion, Vector3};

use crate::angle::Angle;
use crate::camera::Camera;
use crate::distortion::Distortion;
use crate::error::{Error, ParseErrorKind, Result};
use crate::intrinsics::{ImageSize, Intrinsics};

/// Largest entry of `R^T R - I` accepted as a rotation in a camera file.
pub const ROTATION_TOLERANCE: f64 = 1e-5;

/// One camera of a Middlebury `*_par.txt` file: `P = K [R | t]`.
#[derive(Debug, Clone, PartialEq)]
pub struct MiddleburyView {
    /// Image file name, relative to the par file's folder.
    pub image: String,
    /// `K`.
    pub intrinsics: Intrinsics,
    /// `[R | t]`, with R re-orthonormalised.
    pub cam_from_world: Isometry3<f64>,
}

impl MiddleburyView {
    /// The camera for an image of `size` (the Middlebury sets have no lens distortion).
    pub fn camera(&self, size: ImageSize) -> Result<Camera> {
        Camera::new(self.intrinsics, Distortion::NONE, self.cam_from_world, size)
    }
}

/// One line of a Middlebury `*_ang.txt` file.
#[derive(Debug, Clone, PartialEq)]
pub struct MiddleburyAngles {
    /// Gantry latitude.
    pub latitude: Angle,
    /// Gantry longitude.
    pub longitude: Angle,
    /// Image file name.
    pub image: String,
}

fn parse_error(source_name: &str, line: usize, kind: ParseErrorKind) -> Error {
    Error::Parse {
        source_name: source_name.to_owned(),
        line,
        kind,
    }
}

fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_owned(),
        source,
    })
}

/// Parses whitespace-separated numbers; `first_index` is the 1-based field index of the
/// first one (for messages).
fn numbers(fields: &[&str], first_index: usize) -> Result<Vec<f64>, ParseErrorKind> {
    fields
        .iter()
        .enumerate()
        .map(|(i, text)| {
            let value: f64 = text.parse().map_err(|_| ParseErrorKind::NotANumber {
                index: first_index + i,
                text: (*text).to_owned(),
            })?;
            if !value.is_finite() {
                return Err(ParseErrorKind::NotFinite {
                    index: first_index + i,
                    value,
                });
            }
            Ok(value)
        })
        .collect()
}

/// Checks that `r` is a rotation and returns the nearest exact one.
fn rotation(r: &Matrix3<f64>) -> Result<UnitQuaternion<f64>, ParseErrorKind> {
    let orthogonality_error = (r.transpose() * r - Matrix3::identity()).amax();
    let determinant = r.determinant();
    if !(orthogonality_error <= ROTATION_TOLERANCE) || determinant <= 0.0 {
        return Err(ParseErrorKind::NotARotation {
            orthogonality_error,
            determinant,
        });
    }
    Ok(crate::turntable::nearest_rotation(r))
}

/// Non-empty, non-comment lines with their 1-based numbers.
fn content_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

/// Parses a Middlebury `*_par.txt`: a count line, then per image
/// `name k11..k33 r11..r33 t1 t2 t3`.
pub fn parse_middlebury_par(text: &str, source_name: &str) -> Result<Vec<MiddleburyView>> {
    let mut lines = content_lines(text);
    let Some((count_line, count_text)) = lines.next() else {
        return Err(parse_error(source_name, 1, ParseErrorKind::Empty));
    };
    let declared: usize = count_text.parse().map_err(|_| {
        parse_error(
            source_name,
            count_line,
            ParseErrorKind::BadCount {
                text: count_text.to_owned(),
            },
        )
    })?;
    let mut views = Vec::with_capacity(declared.min(4096));
    for (line, content) in lines {
        let fields: Vec<&str> = content.split_whitespace().collect();
        let err = |kind| parse_error(source_name, line, kind);
        if fields.len() != 22 {
            return Err(err(ParseErrorKind::FieldCount {
                expected: 22,
                found: fields.len(),
            }));
        }
        let v = numbers(&fields[1..], 2).map_err(err)?;
        let k = Matrix3::from_row_slice(&v[0..9]);
        let intrinsics = Intrinsics::from_matrix(&k).map_err(|e| {
            err(ParseErrorKind::BadIntrinsics {
                reason: e.to_string(),
            })
        })?;
        let r = rotation(&Matrix3::from_row_slice(&v[9..18])).map_err(err)?;
        let t = Vector3::new(v[18], v[19], v[20]);
        views.push(MiddleburyView {
            image: fields[0].to_owned(),
            intrinsics,
            cam_from_world: Isometry3::from_parts(Translation3::from(t), r),
        });
    }
    if views.len() != declared {
        return Err(parse_error(
            source_name,
            count_line,
            ParseErrorKind::CountMismatch {
                declared,
                found: views.len(),
            },
        ));
    }
    Ok(views)
}

/// Reads a Middlebury `*_par.txt` file.
pub fn read_middlebury_par(path: impl AsRef<Path>) -> Result<Vec<MiddleburyView>> {
    let path = path.as_ref();
    parse_middlebury_par(&read_text(path)?, &path.display().to_string())
}

/// Parses a Middlebury `*_ang.txt`: per image `latitude longitude name`, degrees.
pub fn parse_middlebury_ang(text: &str, source_name: &str) -> Result<Vec<MiddleburyAngles>> {
    let mut out = Vec::new();
    for (line, content) in content_lines(text) {
        let fields: Vec<&str> = content.split_whitespace().collect();
        let err = |kind| parse_error(source_name, line, kind);
        if fields.len() != 3 {
            return Err(err(ParseErrorKind::FieldCount {
                expected: 3,
                found: fields.len(),
            }));
        }
        let v = numbers(&fields[..2], 1).map_err(err)?;
        out.push(MiddleburyAngles {
            latitude: Angle::from_degrees(v[0]),
            longitude: Angle::from_degrees(v[1]),
            image: fields[2].to_owned(),
        });
    }
    if out.is_empty() {
        return Err(parse_error(source_name, 1, ParseErrorKind::Empty));
    }
    Ok(out)
}

/// Reads a Middlebury `*_ang.txt` file.
pub fn read_middlebury_ang(path: impl AsRef<Path>) -> Result<Vec<MiddleburyAngles>> {
    let path = path.as_ref();
    parse_middlebury_ang(&read_text(path)?, &path.display().to_string())
}

/// Parses a plain file of 3x4 projection matrices.
///
/// Each matrix is 12 numbers in row-major order, either on one line or on three lines of
/// four. Blank lines and lines starting with `#` are ignored. An optional first line holding
/// a single integer is the matrix count and must agree with the matrices that follow.
pub fn parse_projection_matrices(text: &str, source_name: &str) -> Result<Vec<Matrix3x4<f64>>> {
    let mut lines = content_lines(text).peekable();
    let mut declared = None;
    if let Some(&(line, content)) = lines.peek() {
        if content.split_whitespace().count() == 1 {
            let n: usize = content.parse().map_err(|_| {
                parse_error(
                    source_name,
                    line,
                    ParseErrorKind::BadCount {
                        text: content.to_owned(),
                    },
                )
            })?;
            declared = Some((line, n));
            lines.next();
        }
    }
    let mut out = Vec::new();
    let mut pending: Vec<f64> = Vec::with_capacity(12);
    let mut last_line = 1;
    for (line, content) in lines {
        last_line = line;
        let fields: Vec<&str> = content.split_whitespace().collect();
        let err = |kind| parse_error(source_name, line, kind);
        match (fields.len(), pending.len()) {
            (12, 0) | (4, 0 | 4 | 8) => {}
            (found, 0) => {
                return Err(err(ParseErrorKind::FieldCount {
                    expected: 12,
                    found,
                }));
            }
            (found, _) => {
                return Err(err(ParseErrorKind::FieldCount { expected: 4, found }));
            }
        }
        pending.extend(numbers(&fields, pending.len() % 12 + 1).map_err(err)?);
        if pending.len() == 12 {
            out.push(Matrix3x4::from_row_slice(&pending));
            pending.clear();
        }
    }
    if !pending.is_empty() {
        return Err(parse_error(
            source_name,
            last_line,
            ParseErrorKind::Truncated {
                rows: pending.len() / 4,
            },
        ));
    }
    if let Some((line, n)) = declared {
        if n != out.len() {
            return Err(parse_error(
                source_name,
                line,
                ParseErrorKind::CountMismatch {
                    declared: n,
                    found: out.len(),
                },
            ));
        }
    }
    if out.is_empty() {
        return Err(parse_error(source_name, last_line, ParseErrorKind::Empty));
    }
    Ok(out)
}

/// Reads a plain file of 3x4 projection matrices (see [`parse_projection_matrices`]).
pub fn read_projection_matrices(path: impl AsRef<Path>) -> Result<Vec<Matrix3x4<f64>>> {
    let path = path.as_ref();
    parse_projection_matrices(&read_text(path)?, &path.display().to_string())
}
