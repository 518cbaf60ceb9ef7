//! Test support for aibr: where the real data lives, and what a test does when it is absent.
//!
//! Real data (Middlebury rings, the OpenCV chessboard set) is kept outside the repository, in
//! `../shared/data` beside the workspace root. Tests find it through the environment variable
//! `AIBR_DATA_DIR` (a relative value is taken relative to the workspace root, because cargo
//! runs each crate's tests in that crate's folder).
//!
//! A test that needs a data set calls [`dataset`]: when the folder is missing it prints one
//! clear skip line and returns `None`, unless `AIBR_REQUIRE_DATA=1` (set by `.ci/run`), in
//! which case absence fails the test.
//!
//! ```
//! // In a test: skip (or fail under AIBR_REQUIRE_DATA=1) when the data set is absent.
//! if let Some(dir) = aibr_testdata::dataset("middlebury-templeSparseRing") {
//!     assert!(dir.join("templeSR_par.txt").is_file());
//! }
//! ```

use std::path::{Path, PathBuf};

/// The workspace root (two levels above this crate).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The shared data folder: `AIBR_DATA_DIR`, or `../shared/data` beside the workspace root.
pub fn data_dir() -> PathBuf {
    match std::env::var_os("AIBR_DATA_DIR") {
        Some(dir) if !dir.is_empty() => {
            let dir = PathBuf::from(dir);
            if dir.is_absolute() {
                dir
            } else {
                workspace_root().join(dir)
            }
        }
        _ => workspace_root().join("../shared/data"),
    }
}

/// True when `AIBR_REQUIRE_DATA` is set to `1` (absent data is then a failure).
pub fn data_required() -> bool {
    std::env::var("AIBR_REQUIRE_DATA").is_ok_and(|v| v == "1")
}

/// The folder of data set `name`, or `None` after printing a skip line when it is absent.
///
/// # Panics
/// When the data set is absent and `AIBR_REQUIRE_DATA=1`: a missing data set must fail CI
/// rather than pass silently.
#[allow(clippy::panic)]
pub fn dataset(name: &str) -> Option<PathBuf> {
    let dir = data_dir().join(name);
    if dir.is_dir() {
        return Some(dir);
    }
    if data_required() {
        panic!(
            "data set {name} not found at {} and AIBR_REQUIRE_DATA=1 (set AIBR_DATA_DIR)",
            dir.display()
        );
    }
    eprintln!(
        "SKIP: data set {name} not found at {} (set AIBR_DATA_DIR to run this test)",
        dir.display()
    );
    None
}
