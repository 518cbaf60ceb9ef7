#!/usr/bin/env python3
"""Active capture with 24 views against uniform capture with 48, per turn of the scene.

    python3 docs/scripts/common_24_48.py EVAL.json [UNIFORM.json]

EVAL.json is the output of `aibr eval --turns ... --json`. For each turn it prints each
strategy's mean masked PSNR over its own novel views (the issue's measure: every angle its
views did not take) and over the novel views both scored (the angles neither captured), then
the means over the turns. Uniform capture's 48 views are taken from UNIFORM.json when given
(a run with uniform capture at the same turns), so that EVAL.json may come from a run of
`--strategy active` alone.

When EVAL.json was run with `--arc`, a second table splits the angles neither captured by that
arc of the object (the mirror's side of `mirror` with `--arc 20:160`): each strategy's mean on
the arc and off it, as `aibr eval` splits its own novel views (an angle is on the arc when the
pan plus the scene's turn lies between the arc's ends, ends included). For a run made without
`--arc`, give the arc as `ARC=FROM:TO` (degrees) in the environment; it is read only when the
run recorded no arc. The table is left out when some turn has no such angle on one side.
"""
import json
import os
import sys


def mean(values):
    return sum(values) / len(values)


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"{path}: {e}")


def checkpoint(path, turns, turn_deg, strategy, views):
    """The checkpoint of `strategy` at `views` views in the run at `turn_deg`."""
    for turn in turns:
        if turn["turn_deg"] != turn_deg:
            continue
        for r in turn["results"]:
            if r["strategy"] != strategy:
                continue
            for c in r["checkpoints"]:
                if c["views"] == views:
                    return c
    sys.exit(f"{path}: turn {turn_deg} has no checkpoint for {strategy} at {views} views")


def on_arc(arc, pan_deg):
    """Whether the novel view at `pan_deg` sees the object's arc `arc` (`aibr eval`'s rule)."""
    span = (arc["to_deg"] - arc["from_deg"]) % 360.0
    return (pan_deg + arc["scene_turn_deg"] - arc["from_deg"]) % 360.0 <= span + 1e-9


def arc_from_env(turn_deg):
    """The arc `ARC=FROM:TO` names, at the scene's turn `turn_deg`; None without `ARC`."""
    text = os.environ.get("ARC")
    if text is None:
        return None
    try:
        start, end = (float(x) for x in text.split(":"))
    except ValueError:
        sys.exit(f"ARC={text}: expected FROM:TO in degrees, such as 20:160")
    return {"from_deg": start, "to_deg": end, "scene_turn_deg": turn_deg}


def active_on_arc(arc, pans_deg):
    """How many of the captured views at `pans_deg` lie on the object's arc."""
    return sum(1 for p in pans_deg if on_arc(arc, p))


def main(path, uniform_path):
    doc = load(path)
    uniform_turns = load(uniform_path)["turns"] if uniform_path != path else doc["turns"]
    rows = []
    sides = []
    for turn in doc["turns"]:
        active = checkpoint(path, doc["turns"], turn["turn_deg"], "active", 24)
        uniform = checkpoint(uniform_path, uniform_turns, turn["turn_deg"], "uniform", 48)
        a = {round(v["pan_deg"], 6): v["masked_psnr_db"] for v in active["novel_views"]}
        u = {round(v["pan_deg"], 6): v["masked_psnr_db"] for v in uniform["novel_views"]}
        both = set(a) & set(u)
        rows.append((
            turn["turn_deg"],
            mean(list(a.values())),
            mean(list(u.values())),
            mean([a[p] for p in both]),
            mean([u[p] for p in both]),
            len(both),
        ))
        arc = active.get("arc") or arc_from_env(turn["turn_deg"])
        inside = [p for p in both if arc is not None and on_arc(arc, p)]
        outside = [p for p in both if arc is not None and not on_arc(arc, p)]
        if inside and outside:
            sides.append((
                turn["turn_deg"],
                mean([a[p] for p in inside]),
                mean([u[p] for p in inside]),
                mean([a[p] for p in outside]),
                mean([u[p] for p in outside]),
                active_on_arc(arc, active["pans_deg"]),
            ))
    print("turn   own angles: active 24, uniform 48, lead | neither captured: the same, angles")
    for t, a, u, ac, uc, n in rows:
        print(f"{t:5} {a:19.2f} {u:11.2f} {a - u:+6.2f} | {ac:23.2f} {uc:8.2f} {ac - uc:+6.2f} {n:4}")
    a, u, ac, uc = (mean([r[i] for r in rows]) for i in range(1, 5))
    print(f"mean  {a:19.2f} {u:11.2f} {a - u:+6.2f} | {ac:23.2f} {uc:8.2f} {ac - uc:+6.2f}")
    if len(sides) != len(rows):
        return
    print()
    print("turn   neither captured, on the arc: active, uniform, lead | off it: the same"
          " | active's views on the arc")
    for t, ai, ui, ao, uo, n in sides:
        print(f"{t:5} {ai:38.2f} {ui:8.2f} {ai - ui:+6.2f} | {ao:14.2f} {uo:8.2f} {ao - uo:+6.2f}"
              f" | {n:4}")
    ai, ui, ao, uo, n = (mean([r[i] for r in sides]) for i in range(1, 6))
    print(f"mean  {ai:38.2f} {ui:8.2f} {ai - ui:+6.2f} | {ao:14.2f} {uo:8.2f} {ao - uo:+6.2f}"
          f" | {n:4.1f}")


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[-1])
