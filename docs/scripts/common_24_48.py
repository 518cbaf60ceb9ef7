#!/usr/bin/env python3
"""Active capture with 24 views against uniform capture with 48, per turn of the scene.

    python3 docs/scripts/common_24_48.py EVAL.json

EVAL.json is the output of `aibr eval --turns ... --json`. For each turn it prints each
strategy's mean masked PSNR over its own novel views (the issue's measure: every angle its
views did not take) and over the novel views both scored (the angles neither captured), then
the means over the turns.
"""
import json
import sys


def mean(values):
    return sum(values) / len(values)


def main(path):
    try:
        with open(path) as f:
            doc = json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"{path}: {e}")
    rows = []
    for turn in doc["turns"]:
        by = {r["strategy"]: {c["views"]: c for c in r["checkpoints"]} for r in turn["results"]}
        try:
            active, uniform = by["active"][24], by["uniform"][48]
        except KeyError as missing:
            sys.exit(f"{path}: turn {turn['turn_deg']} has no checkpoint for {missing}")
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
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
