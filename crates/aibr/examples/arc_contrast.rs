//! Does the consistency estimate tell a view-dependent surface from a Lambertian one?
//!
//! `cargo run --release -p aibr --example arc_contrast -- [--views K,...] [--arcs] SESSION...`
//!
//! For each session, from its first `K` views (capture order; default all of them): every
//! arc between neighbouring views is scored as the active planner scores it (from a 96^3
//! model: [`aibr::pair_scores`]). Prints, per `K`, the arcs' contrast
//! ([`aibr::consistency::arc_contrast`]: the worst arc's compared share, how inconsistent
//! the pixels the model explains are, over the median arc's), which `--faces-first auto`
//! reads from the initial views; and the same with each arc's compared share divided by its
//! width first, a contrast that might serve for uneven arcs. With `--arcs`, also every arc:
//! its pans, its whole share (unexplained pixels counting 1 each), the share of its pixels
//! the model left unexplained, its compared share, and the pixels it looked at. Figures in
//! `docs/results.md` ("Session 75", "Session 77").

use std::path::Path;

use aibr::Session;
use aibr::consistency::{PairScore, arc_contrast};

/// The worst of `xs` over their median (the upper one of an even count), as
/// [`arc_contrast`] takes it.
fn contrast(mut xs: Vec<f64>) -> Option<f64> {
    xs.sort_by(f64::total_cmp);
    let (worst, median) = (*xs.last()?, xs[xs.len() / 2]);
    (median > 0.0).then(|| worst / median)
}

/// One arc of `--arcs`: from and to (degrees), the whole share, the share of the pixels
/// looked at that the model left unexplained, the compared share, the pixels looked at.
fn print_arc(s: &PairScore, pans: &[aibr::camera::Angle]) {
    let looked = s.compared_pixels + s.unexplained_pixels;
    let shown = |x: Option<f64>| x.map_or("-".into(), |x| format!("{x:.3}"));
    let unexplained = (looked > 0).then(|| s.unexplained_pixels as f64 / looked as f64);
    println!(
        "  arc {:7.2} to {:7.2} deg | share {} | unexplained {} | compared share {} | {} px",
        pans[s.a].degrees(),
        pans[s.b].degrees(),
        shown(s.share()),
        shown(unexplained),
        shown(s.compared_share()),
        looked,
    );
}

/// `--views 12,16,24` as counts.
fn parse_views(list: &str) -> Result<Vec<usize>, String> {
    list.split(',')
        .map(|k| {
            k.trim()
                .parse::<usize>()
                .ok()
                .filter(|k| *k >= 2)
                .ok_or(format!("--views: {k:?} is not a view count of 2 or more"))
        })
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut counts: Option<Vec<usize>> = None;
    let mut arcs = false;
    // The options, in either order, before the sessions.
    loop {
        match args.first().map(String::as_str) {
            Some("--views") => {
                let list = args.get(1).ok_or("--views needs a list, e.g. 12,16,24")?;
                counts = Some(parse_views(list)?);
                args.drain(..2);
            }
            Some("--arcs") => {
                arcs = true;
                args.remove(0);
            }
            _ => break,
        }
    }
    if args.is_empty() {
        return Err("usage: arc_contrast [--views K,K,...] [--arcs] SESSION...".into());
    }
    println!("session | views | contrast | per radian");
    for dir in &args {
        let session = Session::open(Path::new(dir))?;
        let views = session.load_views()?;
        let counts = counts.clone().unwrap_or(vec![views.len()]);
        for &k in counts.iter().filter(|&&k| k <= views.len()) {
            let (pans, scores) = aibr::pair_scores(&session, &views[..k], 96)?;
            let width = |s: &PairScore| {
                (pans[s.b].radians() - pans[s.a].radians()).rem_euclid(std::f64::consts::TAU)
            };
            let per_radian: Vec<f64> = scores
                .iter()
                .filter(|s| width(s) > 0.0)
                .filter_map(|s| Some(s.compared_share()? / width(s)))
                .collect();
            let shown = |c: Option<f64>| c.map_or("-".into(), |c| format!("{c:.2}"));
            println!(
                "{dir} | {k} | {} | {}",
                shown(arc_contrast(&scores)),
                shown(contrast(per_radian))
            );
            if arcs {
                for s in &scores {
                    print_arc(s, &pans);
                }
            }
        }
    }
    Ok(())
}
