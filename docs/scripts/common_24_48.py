#!/usr/bin/env python3
"""Active capture with 24 views against uniform capture with 48, per turn of the scene.

    python3 docs/scripts/common_24_48.py EVAL.json [UNIFORM.json]

EVAL.json is the output of `aibr eval --turns ... --json`. For each turn it prints each
strategy's mean masked PSNR over its own novel views (the issue's measure: every angle its
views did not take) and over the novel views both scored (the angles neither captured), then
the means over the turns. Uniform capture's 48 views are taken from UNIFORM.json when given
(a run with uniform capture at the same turns), so that EVAL.json may come from a run of
`--strategy active` alone.
"""
import json
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


def main(path, uniform_path):
    doc = load(path)
    uniform_turns = load(uniform_path)["turns"] if uniform_path != path else doc["turns"]
    rows = []
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
    print("turn   own angles: active 24, uniform 48, lead | neither captured: the same, angles")
    for t, a, u, ac, uc, n in rows:
        print(f"{t:5} {a:19.2f} {u:11.2f} {a - u:+6.2f} | {ac:23.2f} {uc:8.2f} {ac - uc:+6.2f} {n:4}")
    a, u, ac, uc = (mean([r[i] for r in rows]) for i in range(1, 5))
    print(f"mean  {a:19.2f} {u:11.2f} {a - u:+6.2f} | {ac:23.2f} {uc:8.2f} {ac - uc:+6.2f}")


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[-1])
