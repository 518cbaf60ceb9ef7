#!/usr/bin/env python3
"""Active capture with few views against uniform capture with many, turn by turn.

    python3 docs/scripts/stretch_gap.py RUN.json [RUN.json ...] [--views A:U] [--arc FROM:TO]

Each RUN.json is an `aibr eval --turns ... --json` run of both strategies. For each file it
prints, as markdown, active capture at A views (default 24) minus uniform capture at U views
(default 48) in the mean masked PSNR: per turn, then the mean over the turns +- its standard
error, also on the object's arc FROM:TO (degrees of the object's own pan, default 20:160, the
side from which `mirror`'s panel is seen) and off it, with both levels. That is issue 7's goal
beyond the paper ("active with 24 views at least matches uniform with 48").

Given several files, it also says whether they hold the same view sets turn by turn: runs of
`aibr eval --model ...` on one `--work` folder render the same captures from different
geometry, and only then does a difference between the files measure the geometry alone.
"""
import argparse

from compare_turns import arc_psnr, checkpoint, load_turns, mean, object_arc, stderr


def view_counts(value):
    """`A:U`, the active and uniform view counts."""
    try:
        a, u = (int(x) for x in value.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{value!r}: expected A:U, two view counts")
    return a, u


def main():
    parser = argparse.ArgumentParser(usage=__doc__)
    parser.add_argument("runs", nargs="+")
    parser.add_argument("--views", type=view_counts, default=(24, 48))
    parser.add_argument("--arc")
    args = parser.parse_args()
    (na, nu), (lo, hi) = args.views, object_arc(args.arc)
    sets = {}
    for path in args.runs:
        turns = load_turns(path)
        rows = []
        for turn in sorted(turns):
            a = checkpoint(turns[turn], "active", na, path, turn)
            u = checkpoint(turns[turn], "uniform", nu, path, turn)
            side = lambda c, there: arc_psnr(c, turn, lo, hi, there)
            rows.append(
                (
                    turn,
                    a["mean_masked_psnr_db"],
                    u["mean_masked_psnr_db"],
                    side(a, True),
                    side(u, True),
                    side(a, False),
                    side(u, False),
                )
            )
            key = lambda c: tuple(sorted(round(p, 6) for p in c["pans_deg"]))
            sets.setdefault(path, {})[turn] = (key(a), key(u))
        col = lambda i: [r[i] for r in rows]
        gap = lambda i, j: [r[i] - r[j] for r in rows]
        f = lambda xs: f"{mean(xs):+.2f} ± {stderr(xs):.2f}"
        ahead = sum(1 for x in gap(1, 2) if x >= 0)
        print(f"{path}: active at {na} views - uniform at {nu}, arc {lo:g}:{hi:g}")
        print("| turn | active | uniform | active - uniform | on the arc | off it |")
        print("|---|---|---|---|---|---|")
        for t, a, u, sa, su, oa, ou in rows:
            print(f"| {t:g} | {a:.2f} | {u:.2f} | {a - u:+.2f} | {sa - su:+.2f} | {oa - ou:+.2f} |")
        print(
            f"| mean | {mean(col(1)):.2f} ({mean(col(3)):.2f} / {mean(col(5)):.2f}) "
            f"| {mean(col(2)):.2f} ({mean(col(4)):.2f} / {mean(col(6)):.2f}) "
            f"| {f(gap(1, 2))} ({ahead}/{len(rows)} level or ahead) | {f(gap(3, 4))} | {f(gap(5, 6))} |"
        )
        print()
    first = sets[args.runs[0]]
    for path in args.runs[1:]:
        differ = [t for t in first if sets[path].get(t) != first[t]]
        if set(sets[path]) != set(first):
            print(f"{path}: other turns than {args.runs[0]}")
        elif differ:
            turns = ", ".join(f"{t:g}" for t in differ)
            print(f"{path}: other view sets than {args.runs[0]} at turns {turns}")
        else:
            print(f"{path}: the same view sets as {args.runs[0]} at every turn")


if __name__ == "__main__":
    main()
