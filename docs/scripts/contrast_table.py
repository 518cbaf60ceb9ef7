#!/usr/bin/env python3
"""The arcs' contrast of K uniform views on every catalogue scene, as `--faces-first auto` reads it.

    python3 docs/scripts/contrast_table.py WORK [K ...]        (default K: 12 8)

For each K, each scene and each of issue 7's twelve placements (turns 0, 2.5, ..., 27.5), it
captures K uniform views into WORK/SCENE@TURN-K (kept, and reused when there) with
`aibr capture --strategy uniform --max K`, scores them with the example
`arc_contrast` (the arcs' contrast, `aibr::consistency::arc_contrast`, from a 96^3 model as
the capture loop makes it; and the same with each arc's compared share divided by its width),
and prints per scene the range and median over the placements and at how many `auto` serves
faces first (a contrast of 2 or more, `aibr::consistency::VIEW_DEPENDENT_CONTRAST`).

Build first: `cargo build --release -p aibr-cli && cargo build --release -p aibr --example
arc_contrast`. The binaries are taken from target/release, or from $CARGO_TARGET_DIR/release.
This is how docs/results.md, "Session 75" and "Session 77", separates the mirror scenes from
the matte ones (since session 77 the contrast reads only the pixels the model explains).
"""
import os
import statistics
import subprocess
import sys

SCENES = ["lambertian", "head", "chair", "mirror", "mirror-broad"]
TURNS = ["0", "2.5", "5", "7.5", "10", "12.5", "15", "17.5", "20", "22.5", "25", "27.5"]
SERVE_AT = 2.0  # aibr::consistency::VIEW_DEPENDENT_CONTRAST


def contrasts(aibr, example, work, scene, turn, k):
    """(contrast, per radian) of K uniform views of SCENE turned TURN degrees."""
    session = os.path.join(work, f"{scene}@{turn}-{k}")
    if not os.path.exists(os.path.join(session, "session.json")):
        subprocess.run(
            [aibr, "capture", "--rig", f"sim:{scene}@{turn}", "--strategy", "uniform",
             "--max", str(k), "--out", session],
            check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    out = subprocess.run([example, session], check=True, capture_output=True, text=True).stdout
    row = [cell.strip() for cell in out.splitlines()[1].split("|")]
    return float(row[2]), float(row[3])


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    work = sys.argv[1]
    counts = [int(k) for k in sys.argv[2:]] or [12, 8]
    release = os.path.join(os.environ.get("CARGO_TARGET_DIR", "target"), "release")
    aibr = os.path.join(release, "aibr")
    example = os.path.join(release, "examples", "arc_contrast")
    for tool in (aibr, example):
        if not os.access(tool, os.X_OK):
            sys.exit(f"{tool} is missing: build it first (see the docstring)")
    print("| views | scene | contrast: range (median) | served at | per radian: range |")
    print("|---|---|---|---|---|")
    for k in counts:
        for scene in SCENES:
            got = [contrasts(aibr, example, work, scene, t, k) for t in TURNS]
            c = [x for x, _ in got]
            r = [x for _, x in got]
            print(f"| {k} | `{scene}` | {min(c):.2f}-{max(c):.2f} ({statistics.median(c):.2f}) "
                  f"| {sum(x >= SERVE_AT for x in c)} of {len(c)} "
                  f"| {min(r):.2f}-{max(r):.2f} |")


if __name__ == "__main__":
    main()
