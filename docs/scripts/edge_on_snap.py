#!/usr/bin/env python3
"""A planner's 24 views on `mirror` with the views nearest the box's true edge-on pans moved onto
them: how much the planner loses by aiming at its model's faces rather than the true ones.

    python3 docs/scripts/edge_on_snap.py pans EVAL.json > SNAPPED.txt
    python3 docs/scripts/edge_on_snap.py table LOG EVAL.json UNIFORM.json

`pans` reads active capture's 24 views at each turn of EVAL.json (`aibr eval --turns ...
--json`) and prints, per turn, the distance of the view nearest each true edge-on pan within 1.5
degrees (its signed error; `there` within 0.05 degree, about a step of the turntable, where it
is left; `none` when no view lies that near), then a line `TURN PANS`, the views with those
moved onto the true pans, as `oracle_views` takes them in `PANS`. `table` reads the output of
`oracle_views` run on those lines (each run's output after a line `turn TURN`) and prints, per
turn, the planner's mean masked PSNR (from EVAL.json), the moved set's, uniform capture's 48
views' (from UNIFORM.json), and the moved set against uniform capture's 48 on the angles neither
captured, on the mirror's side and off it. It reads the JSON with `compare_turns.py`'s helpers,
beside it.

The box is `mirror`'s (`crates/scene/src/catalogue.rs`): faces at x = -0.06 and 0.055 m and y =
-0.04 and 0.04 m, vertical; the camera circles at 0.55 m from the axis (`CircularMotion::ring`),
at pan 0 on the -Y side. At object pan phi (the pan plus the scene's turn) its centre is at
(-0.55 sin phi, -0.55 cos phi), so a face x = a is seen edge-on where sin phi = -a / 0.55 and a
face y = b where cos phi = -b / 0.55. The mirror panel lies half a millimetre in front of the -X
face; its edge-on pans are within 0.06 degree of the face's.
"""
import math
import re
import sys

from compare_turns import checkpoint, load_turns, mean, wrap

RADIUS_M = 0.55
PAN_LIMIT_DEG = 158.97  # the rig's range, +-2.775 rad
SNAP_DEG = 1.5
STEP_DEG = 0.05  # about a step of the PTU-46 (0.0514 degree): a view this near is there already


def edge_on_object_pans():
    """(face, object pan in degrees) for every pan that sees one of the box's faces edge-on."""
    out = []
    for x in (-0.06, 0.055):
        a = math.degrees(math.asin(-x / RADIUS_M))
        out += [(f"x={x}", a), (f"x={x}", 180.0 - a)]
    for y in (0.04, -0.04):
        a = math.degrees(math.acos(-y / RADIUS_M))
        out += [(f"y={y}", a), (f"y={y}", -a)]
    return out


EDGE_ON = edge_on_object_pans()


def pans(path):
    turns = load_turns(path)
    for t in sorted(turns):
        views = sorted(checkpoint(turns[t], "active", 24, path, t)["pans_deg"])
        moved = list(views)
        notes = []
        for face, object_pan in EDGE_ON:
            target = wrap(object_pan - t)
            if abs(target) > PAN_LIMIT_DEG:
                continue
            i = min(range(len(views)), key=lambda k: abs(views[k] - target))
            error = views[i] - target
            if abs(error) <= STEP_DEG:
                notes.append(f"{face}@{target:.2f}:there")
            elif abs(error) <= SNAP_DEG:
                notes.append(f"{face}@{target:.2f}:{error:+.2f}")
                moved[i] = target
            else:
                notes.append(f"{face}@{target:.2f}:none")
        print(f"# turn {t}: " + " ".join(notes))
        print(f"{t} " + ",".join(repr(p) for p in sorted(moved)))


NEITHER = re.compile(
    r"on the angles neither captured: the 24 given views (\S+) dB \(panel side (\S+) over \d+ "
    r"angles, the rest (\S+) over \d+\); uniform 48 views (\S+) dB \(panel side (\S+) over \d+ "
    r"angles, the rest (\S+) over"
)
GIVEN = re.compile(r"\S+, 24 given views: (\S+) dB")


def table(log, path, uniform_path):
    turns, uniform = load_turns(path), load_turns(uniform_path)
    rows, turn, given = [], None, None
    try:
        with open(log) as f:
            lines = f.read().splitlines()
    except OSError as e:
        sys.exit(f"{log}: {e}")
    for line in lines:
        if m := re.match(r"turn (\S+)$", line):
            turn, given = float(m.group(1)), None
        elif m := GIVEN.match(line):
            given = float(m.group(1))
        elif (m := NEITHER.match(line)) and turn is not None and given is not None:
            a, ap, ao, u, up, uo = (float(x) for x in m.groups())
            if turn not in turns or turn not in uniform:
                sys.exit(f"{log}: turn {turn:g} is not in both {path} and {uniform_path}")
            planner = checkpoint(turns[turn], "active", 24, path, turn)["mean_masked_psnr_db"]
            u48 = checkpoint(uniform[turn], "uniform", 48, uniform_path, turn)
            u48 = u48["mean_masked_psnr_db"]
            rows.append((turn, planner, given, u48, a, u, ap - up, ao - uo))
    if not rows:
        sys.exit(f"{log}: no turn with a moved set's figures")
    print("turn   planner  moved  uniform 48  moved - planner | neither captured: moved, uniform,"
          " lead; mirror's side, off it")
    for t, p, g, u48, a, u, dp, do in rows:
        print(f"{t:5} {p:8.2f} {g:6.2f} {u48:10.2f} {g - p:+16.2f} | {a:25.2f} {u:8.2f}"
              f" {a - u:+6.2f}; {dp:+6.2f} {do:+6.2f}")
    p, g, u48, a, u, dp, do = (mean([r[i] for r in rows]) for i in range(1, 8))
    print(f"mean  {p:8.2f} {g:6.2f} {u48:10.2f} {g - p:+16.2f} | {a:25.2f} {u:8.2f} {a - u:+6.2f};"
          f" {dp:+6.2f} {do:+6.2f} ({len(rows)} turns)")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "pans":
        pans(sys.argv[2])
    elif len(sys.argv) == 5 and sys.argv[1] == "table":
        table(*sys.argv[2:])
    else:
        sys.exit(__doc__)
