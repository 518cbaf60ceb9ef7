#!/usr/bin/env python3
"""How a novel view's PSNR depends on its distance to the nearest captured view.

    python3 docs/scripts/distance_psnr.py EVAL.json [FROM:TO]

EVAL.json is an `aibr eval --turns ... --json` run (any strategies and checkpoints). Every novel
view of every view set is one sample: its masked PSNR, and how far (degrees) its pan lies from
the nearest captured pan of its set. A novel angle renders better or worse for reasons of its
own (what the object shows there), so each sample is taken relative to the mean over every set
of the same turn that rendered that angle (only angles all of the file's sets rendered count).
The samples are then averaged by whole degrees of distance, on the object's arc FROM:TO
(degrees of the object's own pan, default 20:160, the side from which `mirror`'s panel is
seen) and off it; a scene without an arc counts every angle as off it. Distances of 8 degrees
or more share a bin. This is how docs/results.md, "Session 40", finds that on `mirror`'s panel
side a view renders as well 1 degree from a captured one as 4 degrees from it, and off it
worse with every degree.
"""
import collections
import sys

from compare_turns import load_turns, object_arc, on_arc, wrap


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    turns = load_turns(sys.argv[1])
    lo, hi = object_arc(sys.argv[2] if len(sys.argv) == 3 else None)
    # (turn, whole-degree pan) -> [(distance, on the arc, psnr)], one per set rendering it.
    samples = collections.defaultdict(list)
    sets = collections.Counter()
    for turn_deg, results in turns.items():
        for result in results:
            for checkpoint in result["checkpoints"]:
                sets[turn_deg] += 1
                pans = checkpoint["pans_deg"]
                arc = checkpoint.get("arc")
                for novel in checkpoint["novel_views"]:
                    pan = novel["pan_deg"]
                    distance = min(abs(wrap(pan - p)) for p in pans)
                    on = arc is not None and on_arc(pan, arc["scene_turn_deg"], lo, hi)
                    key = (turn_deg, round(pan))
                    samples[key].append((distance, on, novel["masked_psnr_db"]))
    bins = collections.defaultdict(list)
    for (turn, _), views in samples.items():
        if len(views) < sets[turn]:
            continue
        mean = sum(v[2] for v in views) / len(views)
        for distance, on, psnr in views:
            bins[(on, min(int(distance), 8))].append(psnr - mean)
    print("| nearest captured view (degrees) | on the arc: samples, dB | off it: samples, dB |")
    print("|---|---|---|")
    for d in range(9):
        label = f"{d} to {d + 1}" if d < 8 else "8 or more"
        cells = []
        for on in (True, False):
            xs = bins.get((on, d), [])
            cells.append(f"{len(xs)}, {sum(xs) / len(xs):+.2f}" if xs else "")
        print(f"| {label} | {cells[0]} | {cells[1]} |")


if __name__ == "__main__":
    main()
