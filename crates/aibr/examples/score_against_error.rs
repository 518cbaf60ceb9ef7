//! Does the consistency estimate point where the renders are worst?
//!
//! `cargo run --release -p aibr --example score_against_error -- SESSION VIEWS EVAL_JSON STRATEGY`
//!
//! Scores every arc between neighbouring views of the first `VIEWS` views of `SESSION` (what
//! the active planner ranks, from a 96^3 model: [`aibr::pair_scores`]) and sets each beside
//! the mean squared error of the novel views rendered inside it, read from an
//! `aibr eval --json` file (`STRATEGY`: `active` or `uniform`; its checkpoint of `VIEWS`
//! views must be of the same views, e.g. the eval's own `--work` session). Prints one line
//! per arc and the rank correlations (Spearman) with the error of the planner's key, score
//! times width cubed, and of the score alone. Figures in `docs/results.md` ("Session 22").

use std::path::Path;

use aibr::Session;
use aibr::consistency::PlanParams;
use aibr::render::metrics::pooled_psnr;

/// Ranks of `xs` (0 for the smallest; ties in input order).
fn ranks(xs: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..xs.len()).collect();
    order.sort_by(|&a, &b| xs[a].total_cmp(&xs[b]));
    let mut r = vec![0.0; xs.len()];
    for (rank, &i) in order.iter().enumerate() {
        r[i] = rank as f64;
    }
    r
}

/// Pearson correlation of the ranks.
fn spearman(a: &[f64], b: &[f64]) -> f64 {
    let (ra, rb) = (ranks(a), ranks(b));
    let n = ra.len() as f64;
    let (ma, mb) = (ra.iter().sum::<f64>() / n, rb.iter().sum::<f64>() / n);
    let cov: f64 = ra.iter().zip(&rb).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = ra.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = rb.iter().map(|y| (y - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [dir, views, json, strategy] = args.as_slice() else {
        return Err("usage: score_against_error SESSION VIEWS EVAL_JSON STRATEGY".into());
    };
    let n: usize = views.parse()?;
    let session = Session::open(Path::new(dir))?;
    let loaded = session.load_views()?;
    let first = loaded
        .get(..n)
        .ok_or(format!("{dir} holds fewer than {n} views"))?;
    let (pans, scores) = aibr::pair_scores(&session, first, 96)?;

    let eval: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(json)?)?;
    let checkpoint = eval["results"]
        .as_array()
        .into_iter()
        .flatten()
        .filter(|r| r["strategy"] == strategy.as_str())
        .flat_map(|r| r["checkpoints"].as_array().into_iter().flatten())
        .find(|c| c["views"].as_u64() == Some(n as u64))
        .ok_or(format!("{json}: no {strategy} checkpoint of {n} views"))?;
    let novel: Vec<(f64, f64)> = checkpoint["novel_views"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|v| Some((v["pan_deg"].as_f64()?, v["masked_psnr_db"].as_f64()?)))
        .collect();

    println!("| arc (degrees) | score | score x width^3 | novel views | their PSNR (dB) |");
    println!("|---|---|---|---|---|");
    // The planner's ranking key: score times width to its default power.
    let power = PlanParams::default().width_power;
    let (mut keys, mut raw, mut errors) = (Vec::new(), Vec::new(), Vec::new());
    for s in &scores {
        let (a, b) = (pans[s.a].degrees(), pans[s.b].degrees());
        let inside = novel
            .iter()
            .filter(|(p, _)| *p > a && *p < b)
            .map(|(_, psnr)| *psnr);
        // The PSNR of the arc's mean squared error; none for the opening of the range or an
        // arc with nothing rendered inside.
        let (Some(pooled), true) = (pooled_psnr(inside.clone()), b > a) else {
            continue;
        };
        let key = s.score * (b - a).to_radians().powf(power);
        println!(
            "| {a:.1} to {b:.1} | {:.0} | {key:.1} | {} | {pooled:.2} |",
            s.score,
            inside.count()
        );
        keys.push(key);
        raw.push(s.score);
        errors.push(-pooled); // ranks as the mean squared error does
    }
    println!(
        "rank correlation with the arcs' mean squared error ({} arcs): score x width^3 {:.2}, score alone {:.2}",
        keys.len(),
        spearman(&keys, &errors),
        spearman(&raw, &errors)
    );
    Ok(())
}
