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
pan plus the scene's turn, wrapped to -180..180, lies between the arc's ends, ends included).
For a run made without `--arc`, give the arc as `ARC=FROM:TO` (degrees) in the environment; it
is read only when the run recorded no arc. The table is left out when some turn has no such
angle on one side. The JSON helpers are `compare_turns.py`'s, beside it.
"""
import os
import sys

from compare_turns import checkpoint, load_turns, mean, object_arc, on_arc


def main(path, uniform_path):
    turns = load_turns(path)
    uniform_turns = load_turns(uniform_path) if uniform_path != path else turns
    env_arc = os.environ.get("ARC")
    rows = []
    sides = []
    for turn in sorted(turns):
        active = checkpoint(turns[turn], "active", 24, path, turn)
        if turn not in uniform_turns:
            sys.exit(f"{uniform_path}: no turn {turn:g}")
        uniform = checkpoint(uniform_turns[turn], "uniform", 48, uniform_path, turn)
        a = {round(v["pan_deg"], 6): v["masked_psnr_db"] for v in active["novel_views"]}
        u = {round(v["pan_deg"], 6): v["masked_psnr_db"] for v in uniform["novel_views"]}
        both = set(a) & set(u)
        rows.append((
            turn,
            mean(list(a.values())),
            mean(list(u.values())),
            mean([a[p] for p in both]),
            mean([u[p] for p in both]),
            len(both),
        ))
        arc = active.get("arc")
        if arc is not None:
            lo, hi, scene_turn = arc["from_deg"], arc["to_deg"], arc["scene_turn_deg"]
        elif env_arc is not None:
            (lo, hi), scene_turn = object_arc(env_arc), turn
        else:
            continue
        inside = {p for p in both if on_arc(p, scene_turn, lo, hi)}
        outside = both - inside
        if inside and outside:
            sides.append((
                turn,
                mean([a[p] for p in inside]),
                mean([u[p] for p in inside]),
                mean([a[p] for p in outside]),
                mean([u[p] for p in outside]),
                sum(1 for p in active["pans_deg"] if on_arc(p, scene_turn, lo, hi)),
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
