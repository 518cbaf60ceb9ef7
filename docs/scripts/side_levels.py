#!/usr/bin/env python3
"""Each view set's levels on the object's arc and off it, averaged over the turns.

    python3 docs/scripts/side_levels.py FROM:TO EVAL.json [EVAL.json ...]

Each EVAL.json is the output of `aibr eval --turns ... --json`; FROM:TO is the object's arc
in degrees of its own pan (20:160 is the side from which `mirror`'s panel is seen). For every
strategy and checkpoint of every file, in the order met, it prints as markdown the means over
the turns of: the mean masked PSNR over its novel views (the issue's measure), the same on the
arc and off it, how many novel views lie on each side, and how many of its captured views do.
An angle is on the arc when the pan plus the scene's turn, wrapped to -180..180, lies between
the arc's ends (`compare_turns.on_arc`, as `aibr eval --arc` splits its novel views).

This is how docs/results.md, "Session 74", weighs a view on the mirror's side against one off
it: what uniform capture gains on each side from 24 to 36 to 48 views, beside where active
capture's 24 views stand.
"""
import sys

from compare_turns import arc_psnr, load_turns, mean, object_arc, on_arc


def levels(checkpoint, turn, lo, hi):
    """(issue's measure, on the arc, off it, novel views on, off, captured views on, off)."""
    novel_on = sum(1 for v in checkpoint["novel_views"] if on_arc(v["pan_deg"], turn, lo, hi))
    taken_on = sum(1 for p in checkpoint["pans_deg"] if on_arc(p, turn, lo, hi))
    return (
        checkpoint["mean_masked_psnr_db"],
        arc_psnr(checkpoint, turn, lo, hi, True),
        arc_psnr(checkpoint, turn, lo, hi, False),
        novel_on,
        len(checkpoint["novel_views"]) - novel_on,
        taken_on,
        len(checkpoint["pans_deg"]) - taken_on,
    )


def main(arc, paths):
    lo, hi = object_arc(arc)
    print(
        "| file | strategy | views | the issue's measure | on the arc | off it "
        "| novel views on / off | captured views on / off |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for path in paths:
        turns = load_turns(path)
        rows = {}
        for turn in sorted(turns):
            for result in turns[turn]:
                for c in result["checkpoints"]:
                    key = (result["strategy"], c["views"])
                    rows.setdefault(key, []).append(levels(c, turn, lo, hi))
        for (name, views), per_turn in rows.items():
            m = [mean([r[i] for r in per_turn]) for i in range(7)]
            print(
                f"| {path} | {name} | {views} | {m[0]:.2f} | {m[1]:.2f} | {m[2]:.2f} "
                f"| {m[3]:.1f} / {m[4]:.1f} | {m[5]:.1f} / {m[6]:.1f} |"
            )


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
