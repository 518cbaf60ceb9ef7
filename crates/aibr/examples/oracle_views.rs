//! What a planner that knew the truth would reach: the greedy oracle of arc splitting.
//!
//! `cargo run --release -p aibr --example oracle_views -- SCENE TURN [BUDGET] [COMPARE] [STEP]
//! [SPLITS]`
//!
//! Starts, as `aibr eval` does, from 12 views spread uniformly over the pan range of the
//! synthetic rig `sim:SCENE@TURN`, and adds views one at a time up to `BUDGET` (default 24).
//! Each time it tries `SPLITS` pans evenly inside every arc between neighbouring views
//! (default 1, the middle: the active planner's moves without its aims; 3 also tries the
//! quarters, where the planner's aims may move a split) and keeps the one whose view set
//! renders best against the ground truth: the mean masked PSNR of the novel views every
//! `STEP` degrees (default 1) of the range, not within half a degree of a captured view,
//! rendered from the views' 128^3 voxel coloring model with the default renderer. These are
//! `aibr eval`'s frames (the same sensor noise, seeded by the pan angle), model, renderer and
//! measure, so the figures are comparable with its own. It then measures uniform capture
//! with `BUDGET` and with `COMPARE` views (default 48) the same way.
//!
//! No estimate picks a better next view among the same moves than this oracle does at each
//! step, on the novel views it is scored on (a whole sequence chosen otherwise could still end
//! a little better: greedy choice is not optimal). Its choices fit those novel views: on a grid
//! coarser than `aibr eval`'s degree they can render well there and worse between, so measure
//! the views it chose on every degree (`PANS`, below) before setting its figures against
//! uniform capture's (`docs/results.md`, "Session 63": chosen on a 3-degree grid, every
//! oracle's views fell short of uniform capture with 48 on every degree). It reports each
//! step's choice and its figures on the side from which `mirror`'s panel is seen (the object's
//! pans 20 to 160 degrees) and off it. Each step renders a novel view set per candidate: on a
//! 2-core machine, `mirror` from 12 to 24 views took 41 minutes at `STEP` 1 with `SPLITS` 1, 37
//! minutes at `STEP` 3 with `SPLITS` 3, 72 minutes at `STEP` 3 with `SPLITS` 7 (the eighths),
//! and about an hour and a half at `STEP` 1 with `SPLITS` 3.
//!
//! With `PANS` set in the environment (pans in degrees, comma-separated, as the oracle's
//! last line prints them) it chooses nothing: it measures that view set, then uniform capture
//! with as many views and with `COMPARE`, every `STEP` degrees. A set chosen against the
//! novel views every 3 degrees can so be measured on every degree, two thirds of them views
//! it was not chosen against. Last it measures the set and uniform capture with `COMPARE`
//! views on the novel views neither captured: each mean before leaves out the angles its own
//! views took, and a set whose views sit where rendering is worst leaves out its worst.
//!
//! With `EXCHANGES` set too (a count of rounds), it then searches from that set by exchange
//! instead of by addition: each round drops the view the set loses least without and adds
//! the best of `SPLITS` pans in every arc of the rest, keeping the exchange if the set then
//! renders better (trying the second and third least-missed views if not), and stops after
//! a round that keeps none. The set's size stays; `BUDGET` is not used. A round renders some
//! 90 view sets at `SPLITS` 3 with 24 views: about 13 minutes on a 2-core machine.
//!
//! With `NUDGE` set too (degrees; after the exchanges, if any), it then moves each view in turn
//! that many degrees either way, within the pan range, keeping a move when the set renders
//! better, pass after pass until a pass keeps none: a search near the set, where an exchange
//! searches far from it. A pass renders two sets per view: about 6 minutes with 24 views.
//! Several sizes, comma-separated (`NUDGE=2,1`), are taken in turn, each until a pass keeps
//! none, without rendering anything twice.
//!
//! With `FIXED` set too (to anything), the exchanges and moves leave the set's views that are
//! among the 12 initial uniform views where they are, as a planner starting from them must:
//! the search then asks what the other views can do.
//!
//! With `SHIFTED` set (to anything), every set is scored on the novel views half a `STEP`
//! along from the usual ones (at `STEP` 1, the half degrees), leaving out those within half
//! a degree (or half a `STEP`, if less) of a captured view as `aibr eval` does: a grid no
//! search scored, to tell whether a set's figures hold off the views it was chosen against.

use std::collections::hash_map::Entry;
use std::collections::{HashMap, HashSet};

use aibr::camera::{Aabb, Angle};
use aibr::render::{RenderParams, Renderer, SourceView, metrics};
use aibr::voxel::{ColoringParams, View, VoxelGrid, voxel_coloring};
use aibr::{Calibration, EvalRig, FrameSource, ObjectArc, SimRig, Turntable, uniform_pans};
use image::{GrayImage, RgbImage};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Views `aibr eval` starts from.
const INITIAL: usize = 12;
/// How many of a set's views, those it loses least without, an exchange round tries to
/// replace before it gives up.
const DROPS: usize = 3;
/// The object's pans from which `mirror`'s panel is seen (`aibr eval --arc 20:160`).
fn panel_side() -> ObjectArc {
    ObjectArc {
        from: Angle::from_degrees(20.0),
        to: Angle::from_degrees(160.0),
    }
}

fn number(what: &str, text: &str) -> Result<f64> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("{what}: {text:?} is not a number").into())
}

fn count(what: &str, text: &str) -> Result<usize> {
    text.trim()
        .parse::<usize>()
        .map_err(|_| format!("{what}: {text:?} is not a count of views").into())
}

/// A view captured once: the renderer's source (its camera and image) and its object mask.
struct Shot {
    source: SourceView,
    mask: GrayImage,
}

/// How a set of views renders.
#[derive(Clone, Copy)]
struct Figures {
    /// Mean masked PSNR of every novel view, dB.
    mean: f64,
    /// The same on the panel's side, and how many novel views lie there.
    side: (f64, usize),
    /// The same off it.
    rest: (f64, usize),
}

/// The rig, with every frame and ground-truth view it was asked for kept.
struct Oracle {
    rig: SimRig,
    calibration: Calibration,
    volume: Aabb,
    step: Angle,
    /// How far along from `aibr eval`'s grid the novel views lie: zero, or half a `step`
    /// with `SHIFTED`.
    offset: Angle,
    shots: HashMap<u64, Shot>,
    truths: HashMap<u64, (RgbImage, GrayImage)>,
}

impl Oracle {
    /// Whether the novel or captured view at `pan` sees `mirror`'s panel side.
    fn on_panel_side(&self, pan: Angle) -> bool {
        panel_side().contains(pan + self.rig.turn())
    }

    /// Moves to `pan` and captures there, once per pan; returns the pan reached (a whole
    /// number of the turntable's steps).
    fn shoot(&mut self, pan: Angle) -> Result<Angle> {
        let reached = self.rig.move_to(pan)?;
        if let Entry::Vacant(e) = self.shots.entry(reached.radians().to_bits()) {
            let frame = self.rig.capture()?;
            let mask = frame.mask.ok_or("the synthetic rig gave no object mask")?;
            let source = SourceView {
                camera: self.calibration.camera_at(reached),
                image: frame.image,
            };
            e.insert(Shot { source, mask });
        }
        Ok(reached)
    }

    /// Captures `n` views spread uniformly over the rig's pan range, as `aibr eval` places
    /// them; returns the pans reached.
    fn shoot_uniform(&mut self, n: usize) -> Result<Vec<Angle>> {
        let (range, step) = (self.rig.range(), self.rig.step());
        uniform_pans(&range, step, n)
            .into_iter()
            .map(|p| self.shoot(p))
            .collect()
    }

    /// `"panel side"` if the view at `pan` sees `mirror`'s panel side, else `"off it"`.
    fn side_name(&self, pan: Angle) -> &'static str {
        if self.on_panel_side(pan) {
            "panel side"
        } else {
            "off it"
        }
    }

    /// The pan among `splits` evenly inside every arc between neighbouring views of `pans`
    /// whose view, added to `pans`, renders best, and how the set with it renders; `None` if
    /// no arc is long enough to split.
    fn best_addition(&mut self, pans: &[Angle], splits: usize) -> Result<Option<(Angle, Figures)>> {
        let mut sorted = pans.to_vec();
        sorted.sort_by(|a, b| a.radians().total_cmp(&b.radians()));
        let mut best: Option<(Angle, Figures)> = None;
        // The pans tried: a short arc's splits can round to the same whole step.
        let mut tried = HashSet::new();
        for w in sorted.windows(2) {
            let (a, b) = (w[0].radians(), w[1].radians());
            for k in 1..=splits {
                let t = k as f64 / (splits + 1) as f64;
                let pan = self.shoot(Angle::from_radians(a + t * (b - a)))?;
                if pan == w[0] || pan == w[1] || !tried.insert(pan.radians().to_bits()) {
                    continue; // an arc too short to split there, or a pan already tried
                }
                let mut with = sorted.clone();
                with.push(pan);
                let f = self.measure(&with)?;
                if best.is_none_or(|(_, b)| f.mean > b.mean) {
                    best = Some((pan, f));
                }
            }
        }
        Ok(best)
    }

    /// Reconstructs `pans` (already shot) and measures their novel views.
    fn measure(&mut self, pans: &[Angle]) -> Result<Figures> {
        self.measure_leaving_out(pans, &[])
    }

    /// [`Oracle::measure`], leaving out the novel views near the pans of `others` too: two
    /// sets measured each leaving out the other's are scored on the angles neither captured.
    fn measure_leaving_out(&mut self, pans: &[Angle], others: &[Angle]) -> Result<Figures> {
        let shots = pans
            .iter()
            .map(|p| {
                self.shots
                    .get(&p.radians().to_bits())
                    .ok_or_else(|| format!("pan {:.3} deg was not shot", p.degrees()))
            })
            .collect::<std::result::Result<Vec<&Shot>, _>>()?;
        let views: Vec<View<'_>> = shots
            .iter()
            .map(|s| View {
                camera: &s.source.camera,
                image: &s.source.image,
                mask: Some(&s.mask),
            })
            .collect();
        let grid = VoxelGrid::with_resolution(self.volume, 128)?;
        let model = voxel_coloring(&grid, &views, &ColoringParams::default())?.model;
        let sources = shots.iter().map(|s| s.source.clone()).collect();
        let renderer = Renderer::new(&model, sources, RenderParams::default())?;
        let (mut all, mut side, mut rest) = (Vec::new(), Vec::new(), Vec::new());
        let left_out: Vec<Angle> = pans.iter().chain(others).copied().collect();
        for (pan, camera) in self
            .rig
            .novel_views_offset(&left_out, self.step, self.offset)?
        {
            let (truth, mask) = match self.truths.entry(pan.radians().to_bits()) {
                Entry::Occupied(e) => e.into_mut(),
                Entry::Vacant(e) => e.insert(self.rig.truth(pan, &camera)?),
            };
            let view = renderer.render(&camera)?;
            let psnr = metrics::psnr(truth, &view.rgb, Some(mask))?;
            all.push(psnr);
            if self.on_panel_side(pan) {
                side.push(psnr);
            } else {
                rest.push(psnr);
            }
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        Ok(Figures {
            mean: mean(&all),
            side: (mean(&side), side.len()),
            rest: (mean(&rest), rest.len()),
        })
    }
}

fn describe(f: &Figures) -> String {
    format!(
        "{:.2} dB (panel side {:.2} over {} angles, the rest {:.2} over {})",
        f.mean, f.side.0, f.side.1, f.rest.0, f.rest.1
    )
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let [_, scene, turn, rest @ ..] = args.as_slice() else {
        return Err("usage: oracle_views SCENE TURN [BUDGET] [COMPARE] [STEP] [SPLITS]".into());
    };
    let turn = number("TURN", turn)?;
    let budget = rest.first().map_or(Ok(24), |s| count("BUDGET", s))?;
    let compare = rest.get(1).map_or(Ok(48), |s| count("COMPARE", s))?;
    let step = rest.get(2).map_or(Ok(1.0), |s| number("STEP", s))?;
    let splits = rest.get(3).map_or(Ok(1), |s| count("SPLITS", s))?;
    if budget <= INITIAL {
        return Err(format!("BUDGET {budget}: must exceed the {INITIAL} initial views").into());
    }
    if compare < 3 {
        return Err(format!("COMPARE {compare}: must be 3 views or more").into());
    }
    if splits == 0 {
        return Err("SPLITS 0: at least one pan per arc must be tried".into());
    }
    if !(step > 0.0) {
        return Err(format!("STEP {step}: must be positive").into());
    }
    for search in ["EXCHANGES", "NUDGE"] {
        if std::env::var_os(search).is_some() && std::env::var_os("PANS").is_none() {
            return Err(
                format!("{search} searches from the view set in PANS: set PANS too").into(),
            );
        }
    }
    let rounds = match std::env::var("EXCHANGES") {
        Ok(text) => Some(count("EXCHANGES", &text)?),
        Err(_) => None,
    };
    let mut nudges = Vec::new();
    if let Ok(text) = std::env::var("NUDGE") {
        for size in text.split(',') {
            match number("NUDGE", size)? {
                d if d > 0.0 => nudges.push(Angle::from_degrees(d)),
                d => return Err(format!("NUDGE {d}: must be positive").into()),
            }
        }
    }
    let fixed = std::env::var_os("FIXED").is_some();
    if fixed && rounds.is_none() && nudges.is_empty() {
        return Err("FIXED keeps views in place in a search: set EXCHANGES or NUDGE too".into());
    }
    let rig = SimRig::from_spec(&format!("sim:{scene}@{turn}"))?;
    let mut oracle = Oracle {
        calibration: rig.calibration()?,
        volume: rig.volume(),
        rig,
        step: Angle::from_degrees(step),
        offset: match std::env::var_os("SHIFTED") {
            Some(_) => Angle::from_degrees(0.5 * step),
            None => Angle::ZERO,
        },
        shots: HashMap::new(),
        truths: HashMap::new(),
    };
    if let Ok(given) = std::env::var("PANS") {
        let mut pans = Vec::new();
        for text in given.split(',') {
            let reached = oracle.shoot(Angle::from_degrees(number("PANS", text)?))?;
            if pans.contains(&reached) {
                return Err(format!("PANS: {text} reaches a pan already listed").into());
            }
            pans.push(reached);
        }
        let mut figures = oracle.measure(&pans)?;
        println!(
            "{scene}@{turn}, {} given views: {}",
            pans.len(),
            describe(&figures)
        );
        let mut held = Vec::new();
        if fixed {
            held = oracle.shoot_uniform(INITIAL)?;
            held.retain(|p| pans.contains(p));
            println!(
                "held where they are: {} of the {INITIAL} initial views",
                held.len()
            );
        }
        if let Some(rounds) = rounds {
            figures = exchange(&mut oracle, &mut pans, &held, figures, splits, rounds)?;
            println!(
                "exchanged {} views: {}\n{}",
                pans.len(),
                list(&mut pans),
                describe(&figures)
            );
        }
        for by in nudges {
            figures = nudge(&mut oracle, &mut pans, &held, figures, by)?;
            println!(
                "nudged {} views: {}\n{}",
                pans.len(),
                list(&mut pans),
                describe(&figures)
            );
        }
        measure_uniform(&mut oracle, [pans.len(), compare])?;
        return measure_common(&mut oracle, &pans, compare);
    }
    let mut pans = oracle.shoot_uniform(INITIAL)?;
    let start = oracle.measure(&pans)?;
    println!(
        "{scene}@{turn}, {INITIAL} uniform views: {}",
        describe(&start)
    );
    while pans.len() < budget {
        let Some((pan, f)) = oracle.best_addition(&pans, splits)? else {
            println!("no arc left to split");
            break;
        };
        pans.push(pan);
        println!(
            "{} views: + {:.2} deg ({}): {}",
            pans.len(),
            pan.degrees(),
            oracle.side_name(pan),
            describe(&f)
        );
    }
    println!("oracle's {} views: {}", pans.len(), list(&mut pans));
    measure_uniform(&mut oracle, [pans.len(), compare])
}

/// Sorts `pans` and lists them in degrees, comma-separated, as `PANS` takes them.
fn list(pans: &mut [Angle]) -> String {
    pans.sort_by(|a, b| a.radians().total_cmp(&b.radians()));
    let degrees: Vec<String> = pans.iter().map(|p| format!("{:.2}", p.degrees())).collect();
    degrees.join(",")
}

/// Exchanges views of `pans` (which render as `figures`) for better ones, up to `rounds`
/// times, never dropping those in `held`: a round measures the set without each of its other
/// views, then, for the [`DROPS`] views whose loss costs least in turn, adds the best of
/// `splits` pans in every arc of the set without it ([`Oracle::best_addition`]); the first
/// such exchange that renders better than the set is kept. It stops when a round keeps none.
fn exchange(
    oracle: &mut Oracle,
    pans: &mut Vec<Angle>,
    held: &[Angle],
    mut figures: Figures,
    splits: usize,
    rounds: usize,
) -> Result<Figures> {
    for round in 1..=rounds {
        let mut without = Vec::with_capacity(pans.len());
        for (i, &pan) in pans.iter().enumerate() {
            if held.contains(&pan) {
                continue;
            }
            let mut rest = pans.clone();
            rest.remove(i);
            let mean = oracle.measure(&rest)?.mean;
            without.push((pan, rest, mean));
        }
        without.sort_by(|a, b| b.2.total_cmp(&a.2));
        let mut kept = None;
        for (dropped, rest, mean_without) in without.into_iter().take(DROPS) {
            let Some((added, f)) = oracle.best_addition(&rest, splits)? else {
                continue;
            };
            println!(
                "round {round}: - {:.2} deg ({}, {mean_without:.2} dB without it) + {:.2} deg ({}): {}",
                dropped.degrees(),
                oracle.side_name(dropped),
                added.degrees(),
                oracle.side_name(added),
                describe(&f)
            );
            if f.mean > figures.mean {
                kept = Some((rest, added, f));
                break;
            }
        }
        let Some((rest, added, f)) = kept else {
            println!("round {round}: no exchange renders better; stopped");
            break;
        };
        *pans = rest;
        pans.push(added);
        figures = f;
        println!("after round {round}: {}", list(pans));
    }
    Ok(figures)
}

/// Moves each view of `pans` (which render as `figures`) but those in `held` in turn by `by`
/// either way within the rig's pan range, keeping the better move when it renders better than
/// the set, pass after pass until a pass keeps none.
fn nudge(
    oracle: &mut Oracle,
    pans: &mut [Angle],
    held: &[Angle],
    mut figures: Figures,
    by: Angle,
) -> Result<Figures> {
    let range = oracle.rig.range();
    let size = format!("{:.1}-degree", by.degrees());
    for pass in 1.. {
        let mut moved = 0;
        for i in 0..pans.len() {
            let from = pans[i];
            if held.contains(&from) {
                continue;
            }
            let mut best: Option<(Angle, Figures)> = None;
            for to in [from - by, from + by] {
                if to.radians() < range.min().radians() || to.radians() > range.max().radians() {
                    continue;
                }
                let to = oracle.shoot(to)?;
                if pans.contains(&to) {
                    continue; // a step too short to move, or onto another view
                }
                pans[i] = to;
                let f = oracle.measure(pans)?;
                pans[i] = from;
                if f.mean > best.map_or(figures.mean, |(_, b)| b.mean) {
                    best = Some((to, f));
                }
            }
            if let Some((to, f)) = best {
                println!(
                    "{size} pass {pass}: {:.2} -> {:.2} deg ({}): {}",
                    from.degrees(),
                    to.degrees(),
                    oracle.side_name(to),
                    describe(&f)
                );
                pans[i] = to;
                figures = f;
                moved += 1;
            }
        }
        if moved == 0 {
            println!("{size} pass {pass}: no move renders better; stopped");
            break;
        }
        println!("after {size} pass {pass} ({moved} moved): {}", list(pans));
    }
    Ok(figures)
}

/// Measures `pans` and uniform capture with `compare` views on the novel views neither
/// captured, so that neither mean gains from leaving out angles the other scores.
fn measure_common(oracle: &mut Oracle, pans: &[Angle], compare: usize) -> Result<()> {
    let uniform = oracle.shoot_uniform(compare)?;
    let given = oracle.measure_leaving_out(pans, &uniform)?;
    let other = oracle.measure_leaving_out(&uniform, pans)?;
    println!(
        "on the angles neither captured: the {} given views {}; uniform {compare} views {}",
        pans.len(),
        describe(&given),
        describe(&other)
    );
    Ok(())
}

/// Measures uniform capture with each of `counts` views (once when the two are equal).
fn measure_uniform(oracle: &mut Oracle, counts: [usize; 2]) -> Result<()> {
    let mut last: Option<(usize, Figures)> = None;
    for n in counts {
        let figures = match last {
            Some((m, f)) if m == n => f,
            _ => {
                let uniform = oracle.shoot_uniform(n)?;
                oracle.measure(&uniform)?
            }
        };
        println!("uniform {n} views: {}", describe(&figures));
        last = Some((n, figures));
    }
    Ok(())
}
