//! Bad camera files give typed errors that name the file and the line.

#![allow(clippy::panic)]

use aibr_camera::readers::{
    parse_middlebury_ang, parse_middlebury_par, parse_projection_matrices, read_middlebury_par,
};
use aibr_camera::{Error, ParseErrorKind};

const GOOD: &str = "templeSR0001.png 1520.4 0 302.32 0 1525.9 246.87 0 0 1 \
0.021875982 0.983296808 -0.180689864 0.998567080 -0.012661146 0.051995007 \
0.048838783 -0.181568392 -0.982164798 -0.0726637729648 0.0223360353405 0.614604845959";

fn parse_err(text: &str) -> (usize, ParseErrorKind) {
    match parse_middlebury_par(text, "cams.txt") {
        Err(Error::Parse {
            source_name,
            line,
            kind,
        }) => {
            assert_eq!(source_name, "cams.txt");
            (line, kind)
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn good_line_parses() {
    let views = parse_middlebury_par(&format!("1\n{GOOD}\n"), "cams.txt");
    assert!(views.is_ok_and(|v| v.len() == 1 && v[0].image == "templeSR0001.png"));
}

#[test]
fn wrong_field_count() {
    let (line, kind) = parse_err(&format!("1\n{GOOD} 7\n"));
    assert_eq!(line, 2);
    assert_eq!(
        kind,
        ParseErrorKind::FieldCount {
            expected: 22,
            found: 23
        }
    );
}

#[test]
fn non_numeric_field() {
    let bad = GOOD.replace(" 302.32 ", " 3o2.32 ");
    let (line, kind) = parse_err(&format!("1\n{bad}\n"));
    assert_eq!(line, 2);
    assert!(
        matches!(kind, ParseErrorKind::NotANumber { index: 4, .. }),
        "{kind:?}"
    );
}

#[test]
fn nan_field() {
    let bad = GOOD.replace(" 0.614604845959", " NaN");
    let (line, kind) = parse_err(&format!("1\n\n{bad}\n"));
    assert_eq!(line, 3, "blank lines still count");
    assert!(
        matches!(kind, ParseErrorKind::NotFinite { index: 22, .. }),
        "{kind:?}"
    );
}

#[test]
fn not_a_rotation() {
    let bad = GOOD.replace("0.021875982 0.983296808", "0.121875982 0.983296808");
    let (_, kind) = parse_err(&format!("1\n{bad}\n"));
    assert!(
        matches!(kind, ParseErrorKind::NotARotation { .. }),
        "{kind:?}"
    );
    // A reflection (det = -1) is not a rotation either.
    let reflected = GOOD.replace(
        "0.048838783 -0.181568392 -0.982164798",
        "-0.048838783 0.181568392 0.982164798",
    );
    let (_, kind) = parse_err(&format!("1\n{reflected}\n"));
    assert!(matches!(kind, ParseErrorKind::NotARotation { determinant, .. } if determinant < 0.0));
}

#[test]
fn count_disagrees() {
    let (line, kind) = parse_err(&format!("2\n{GOOD}\n"));
    assert_eq!(line, 1);
    assert_eq!(
        kind,
        ParseErrorKind::CountMismatch {
            declared: 2,
            found: 1
        }
    );
    let (_, kind) = parse_err(&format!("one\n{GOOD}\n"));
    assert!(matches!(kind, ParseErrorKind::BadCount { .. }));
    let (_, kind) = parse_err("");
    assert_eq!(kind, ParseErrorKind::Empty);
}

#[test]
fn bad_intrinsics() {
    let bad = GOOD.replace("1520.4 0 302.32 0 1525.9", "-1520.4 0 302.32 0 1525.9");
    let (_, kind) = parse_err(&format!("1\n{bad}\n"));
    assert!(
        matches!(kind, ParseErrorKind::BadIntrinsics { .. }),
        "{kind:?}"
    );
}

#[test]
fn missing_file_names_the_path() {
    let err = read_middlebury_par("/nonexistent/cams_par.txt");
    let Err(e) = err else {
        panic!("expected an error")
    };
    assert!(e.to_string().contains("/nonexistent/cams_par.txt"), "{e}");
}

#[test]
fn error_message_names_file_and_line() {
    let Err(e) = parse_middlebury_par(&format!("1\n{GOOD} 7\n"), "temple_par.txt") else {
        panic!("expected an error")
    };
    assert_eq!(
        e.to_string(),
        "temple_par.txt:2: expected 22 fields, found 23"
    );
}

#[test]
fn ang_files() {
    let a = parse_middlebury_ang("-82.17 -180.0 a.png\n82.17 12.5 b.png\n", "ang");
    assert!(a.is_ok_and(|a| a.len() == 2 && (a[1].longitude.degrees() - 12.5).abs() < 1e-12));
    assert!(parse_middlebury_ang("-82.17 x a.png\n", "ang").is_err());
    assert!(parse_middlebury_ang("-82.17 a.png\n", "ang").is_err());
}

#[test]
fn matrix_files() {
    let one_line = "1 0 0 0 0 1 0 0 0 0 1 0\n";
    let three_lines = "# a camera\n1 2 3 4\n5 6 7 8\n9 10 11 12\n";
    let m = parse_projection_matrices(&format!("{one_line}\n{three_lines}"), "m.txt");
    assert!(
        m.as_ref()
            .is_ok_and(|m| m.len() == 2 && m[1][(1, 2)] == 7.0),
        "{m:?}"
    );
    assert!(parse_projection_matrices(&format!("2\n{one_line}"), "m.txt").is_err());
    assert!(parse_projection_matrices(&format!("1\n{one_line}"), "m.txt").is_ok());
    let Err(Error::Parse { line, kind, .. }) =
        parse_projection_matrices("1 2 3 4\n5 6 7 8\n", "m.txt")
    else {
        panic!("expected a parse error")
    };
    assert_eq!((line, kind), (2, ParseErrorKind::Truncated { rows: 2 }));
    let Err(Error::Parse { line, kind, .. }) =
        parse_projection_matrices("1 2 3 4\n5 6 7\n", "m.txt")
    else {
        panic!("expected a parse error")
    };
    assert_eq!(
        (line, kind),
        (
            2,
            ParseErrorKind::FieldCount {
                expected: 4,
                found: 3
            }
        )
    );
}
