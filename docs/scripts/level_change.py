#!/usr/bin/env python3
"""How far one `aibr eval --turns ... --json` run's levels moved from another's, placement by placement.

    python3 docs/scripts/level_change.py A.json B.json

Both files are `aibr eval --turns` JSON of the same scene, typically the same captures rendered
two ways (say with and without `--reflections on`). For each strategy and checkpoint it prints
each run's mean masked PSNR (mean over the turns both hold), the mean of A - B over the turns,
the turn where A fell furthest below B and where it rose most, and the same means on the
object's arc (`--arc`; NaN without it). (`compare_turns.py` prints the leads.) This is
how docs/results.md, "Session 49" and "Session 50", say how far an option moved the levels.
"""
import math
import sys

from compare_turns import load_turns


def load(path):
    """The checkpoints of an `aibr eval --turns` JSON by (turn, strategy, views)."""
    return {
        (turn, r["strategy"], c["views"]): c
        for turn, results in load_turns(path).items()
        for r in results
        for c in r["checkpoints"]
    }


def mean(xs):
    """The mean of a non-empty list."""
    return sum(xs) / len(xs)


def on_arc(c):
    """The checkpoint's mean masked PSNR on the arc, NaN without one."""
    arc = c.get("arc") or {}
    return arc.get("on_arc", {}).get("mean_masked_psnr_db", math.nan)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    a = load(sys.argv[1])
    b = load(sys.argv[2])
    keys = sorted(set(a) & set(b))
    if not keys:
        sys.exit("the two runs share no (turn, strategy, views)")
    print(f"{len({k[0] for k in keys})} turns in common")
    for strategy in ("active", "uniform"):
        for views in sorted({k[2] for k in keys}):
            ks = [k for k in keys if k[1] == strategy and k[2] == views]
            if not ks:
                continue
            la = mean([a[k]["mean_masked_psnr_db"] for k in ks])
            lb = mean([b[k]["mean_masked_psnr_db"] for k in ks])
            d = [(a[k]["mean_masked_psnr_db"] - b[k]["mean_masked_psnr_db"], k[0]) for k in ks]
            arc_a = mean([on_arc(a[k]) for k in ks])
            arc_b = mean([on_arc(b[k]) for k in ks])
            print(
                f"{strategy:8s} {views:3d}: A {la:.3f} B {lb:.3f}, A - B {mean([x for x, _ in d]):+.4f}"
                f" (lowest {min(d)[0]:+.4f} at turn {min(d)[1]}, highest {max(d)[0]:+.4f}"
                f" at turn {max(d)[1]}) | on the arc A {arc_a:.3f} B {arc_b:.3f} ({arc_a - arc_b:+.3f})"
            )


if __name__ == "__main__":
    main()
