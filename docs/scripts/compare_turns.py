#!/usr/bin/env python3
"""Active capture from one `aibr eval --turns ... --json` run against uniform capture from another.

    python3 docs/scripts/compare_turns.py ACTIVE.json UNIFORM.json [FROM:TO]

Both files are `aibr eval --turns` JSON over the same turns. The active sets are taken from
ACTIVE.json (typically a run with `--strategy active` and a changed planner), the uniform sets
and the earlier active sets from UNIFORM.json (a run of both strategies; uniform capture does
not depend on the planner, so its sets need not be computed again). For each checkpoint past
the initial views it prints, as markdown, active - uniform in the mean masked PSNR (mean over
the turns +- its standard error, turns ahead), the same for UNIFORM.json's own active sets, on
the angles neither strategy captured, in the pooled PSNR, and on the object's arc FROM:TO
(degrees of the object's own pan, default 20:160, the side from which `mirror`'s panel is
seen) and off it; then the leads by turn (and the worst to a thousandth of a dB), the levels,
and the models' accuracy. This is how docs/results.md, "Session 25", compares the aiming
planner with session 24's runs.
"""
import json
import math
import sys


def load_turns(path):
    """The results of each turn of an `aibr eval --turns` JSON, by turn (degrees)."""
    try:
        with open(path) as f:
            doc = json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        sys.exit(f"{path}: {e}")
    if "turns" not in doc:
        sys.exit(f"{path}: not an `aibr eval --turns` JSON (no 'turns')")
    return {round(t["turn_deg"], 3): t["results"] for t in doc["turns"]}


def object_arc(arg):
    """The object's arc FROM:TO (degrees) of a command line argument; 20:160 without one."""
    if arg is None:
        return 20.0, 160.0
    try:
        lo, hi = (float(x) for x in arg.split(":"))
    except ValueError:
        sys.exit(f"arc {arg!r}: expected FROM:TO in degrees")
    return lo, hi


def wrap(degrees):
    """`degrees` wrapped into [-180, 180)."""
    return (degrees + 180.0) % 360.0 - 180.0


def on_arc(pan, turn, lo, hi):
    """Whether the camera's pan `pan` sees the object, turned by `turn`, from its arc lo:hi."""
    return lo <= wrap(pan + turn) <= hi


def arc_psnr(checkpoint, turn, lo, hi, there):
    """The mean masked PSNR of a checkpoint's novel views on the object's arc lo:hi (`there`)
    or off it, the object turned by `turn`."""
    return mean(
        [
            v["masked_psnr_db"]
            for v in checkpoint["novel_views"]
            if on_arc(v["pan_deg"], turn, lo, hi) == there
        ]
    )


def strategy(results, name, path):
    for r in results:
        if r["strategy"] == name:
            return r
    sys.exit(f"{path}: no {name} results")


def checkpoint(results, name, views, path, turn):
    """The checkpoint at `views` views of strategy `name`."""
    for c in strategy(results, name, path)["checkpoints"]:
        if c["views"] == views:
            return c
    sys.exit(f"{path}: turn {turn:g}: {name} has no checkpoint at {views} views")


def mean(xs):
    return sum(xs) / max(1, len(xs))


def stderr(xs):
    if len(xs) < 2:
        return float("nan")
    m = mean(xs)
    return math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1) / len(xs))


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    active_path, uniform_path = sys.argv[1], sys.argv[2]
    lo, hi = object_arc(sys.argv[3] if len(sys.argv) == 4 else None)
    new, old = load_turns(active_path), load_turns(uniform_path)
    missing = sorted(set(new) - set(old))
    if missing:
        sys.exit(f"{uniform_path}: no turns {missing}")

    rows = {}
    for turn in sorted(new):
        a = strategy(new[turn], "active", active_path)
        u = strategy(old[turn], "uniform", uniform_path)
        a0 = strategy(old[turn], "active", uniform_path)
        for ca, cu, c0 in zip(a["checkpoints"], u["checkpoints"], a0["checkpoints"]):
            n = ca["views"]
            if n != cu["views"] or n != c0["views"]:
                sys.exit(f"turn {turn}: checkpoints differ ({n}, {cu['views']}, {c0['views']})")
            if n == len(a["checkpoints"][0]["pans_deg"]):
                continue  # the initial views: the same for both
            pans = lambda c: {round(v["pan_deg"], 3) for v in c["novel_views"]}
            common = pans(ca) & pans(cu)
            both = lambda c: mean(
                [v["masked_psnr_db"] for v in c["novel_views"] if round(v["pan_deg"], 3) in common]
            )
            side = lambda c, s: arc_psnr(c, turn, lo, hi, s)
            there = lambda c: sum(1 for p in c["pans_deg"] if on_arc(p, turn, lo, hi))
            r = rows.setdefault(n, {})
            for key, value in [
                ("lead", ca["mean_masked_psnr_db"] - cu["mean_masked_psnr_db"]),
                ("before", c0["mean_masked_psnr_db"] - cu["mean_masked_psnr_db"]),
                ("common", both(ca) - both(cu)),
                ("pooled", ca["pooled_masked_psnr_db"] - cu["pooled_masked_psnr_db"]),
                ("side", side(ca, True) - side(cu, True)),
                ("off", side(ca, False) - side(cu, False)),
                ("level", ca["mean_masked_psnr_db"]),
                ("level_side", side(ca, True)),
                ("level_off", side(ca, False)),
                ("there", there(ca)),
                ("u_level", cu["mean_masked_psnr_db"]),
                ("u_side", side(cu, True)),
                ("u_off", side(cu, False)),
                ("u_there", there(cu)),
                ("accuracy", ca["geometry"]["accuracy_voxels"]),
                ("accuracy_before", c0["geometry"]["accuracy_voxels"]),
                ("u_accuracy", cu["geometry"]["accuracy_voxels"]),
                ("turn", turn),
            ]:
                r.setdefault(key, []).append(value)

    k = len(new)
    print(f"turns: {k}; arc {lo:g}:{hi:g}")
    print("| views | mean masked PSNR | before | common angles | pooled | on the arc | off it |")
    print("|---|---|---|---|---|---|---|")
    for n, r in sorted(rows.items()):
        f = lambda key: f"{mean(r[key]):+.2f} ± {stderr(r[key]):.2f}"
        ahead = lambda key: sum(1 for x in r[key] if x > 0)
        print(
            f"| {n} | {f('lead')} ({ahead('lead')}/{k}) | {f('before')} ({ahead('before')}/{k}) "
            f"| {f('common')} ({ahead('common')}/{k}) | {f('pooled')} "
            f"| {f('side')} ({ahead('side')}/{k}) | {f('off')} |"
        )
    for n, r in sorted(rows.items()):
        # The worst to a thousandth: a lead of -0.2047 reads -0.20 to two decimals, within a
        # 0.2 dB bound it misses.
        worst, at = min(zip(r["lead"], r["turn"]))
        print(
            f"{n} by turn: " + " ".join(f"{x:+.2f}" for x in r["lead"])
            + f"; the worst {worst:+.3f} (turn {at:g})"
        )
    for n, r in sorted(rows.items()):
        print(
            f"{n} levels: active {mean(r['level']):.2f} ({mean(r['level_side']):.2f} / "
            f"{mean(r['level_off']):.2f}), {mean(r['there']):.1f} on the arc | uniform "
            f"{mean(r['u_level']):.2f} ({mean(r['u_side']):.2f} / {mean(r['u_off']):.2f}), "
            f"{mean(r['u_there']):.1f}"
        )
    for n, r in sorted(rows.items()):
        print(
            f"{n} accuracy (voxels): active {mean(r['accuracy']):.2f} "
            f"({min(r['accuracy']):.2f}-{max(r['accuracy']):.2f}), before "
            f"{mean(r['accuracy_before']):.2f}, uniform {mean(r['u_accuracy']):.2f}"
        )


if __name__ == "__main__":
    main()
