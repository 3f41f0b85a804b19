//! The rounds: screen the candidates left, refit the promising ones, re-check the base, name one
//! or say why none; from a named effect, the next round starts from the model that includes it.
//!
//! Each round ends in an [`Outcome`]; [`run_rounds`] decides from it whether to go on, do the
//! round again (once, from a better base) or stop with a verdict.

use super::diagnose::diagnose;
use super::evidence::{best_refit_delta_bic, delta_bic, holdout_sse};
use super::explain::explained_share;
use super::fit::POLISH_LIMITS;
use super::refit::{assess, profile_restart, refit};
use super::screen::{scan_starts, screen, CandidateStart};
use super::start::{reproduces_start, StartMiss};
use super::verdict::{
    left_open, shortfalls, CandidateVerdict, ClosestShortfall, Shortfall, Verdict,
};
use super::{
    ensure_jacobian, fit_state, Candidate, Config, Ctx, Data, Diagnosis, FitOut, GapError, Limits,
    ModelState, VisibilityPoint,
};
use crate::policy::{
    ALWAYS_REFIT, BASE_RECHECK_ITERATIONS, BASE_RECHECK_REL_TOL, FAR_FROM_NOISE,
    LATER_ROUND_REFITS, LM_ABS_TOL, MIN_EXPLAINED_SHARE, REFIT_SCORE_FRACTION,
};
use crate::sim::{GridModel, SimError};
use rayon::iter::{IndexedParallelIterator, IntoParallelRefIterator, ParallelIterator};
use std::collections::BTreeMap;

/// What the rounds hand on: the current model and everything the report needs from them.
pub(super) struct Rounds {
    /// The current model (the base fit, then with each named effect) and its weighted residual
    /// over the whole trace.
    pub(super) cur: FitOut,
    pub(super) cur_full_r: Vec<f64>,
    pub(super) named: Vec<String>,
    /// Candidates of each round, ranked.
    pub(super) candidates: Vec<Vec<Candidate>>,
    /// Diagnosis of the base fit, then after each named effect.
    pub(super) diagnosis: Vec<Diagnosis>,
    /// Rounds done again from a better base: (round, ΔBIC of that base over the previous).
    pub(super) redone: Vec<(usize, f64)>,
    /// Why the rounds stopped, when a round named nothing (None: they ran out or the residuals
    /// became noise).
    pub(super) verdict: Option<Verdict>,
    pub(super) unexplained: Option<String>,
}

/// What a round needs from the run that does not change between rounds.
pub(super) struct RoundInputs<'r> {
    pub(super) cfg: &'r Config,
    /// The base parameters as given (their values before calibration).
    pub(super) st0: &'r ModelState,
    /// How the base fit missed the start of the record, when it did (`start`).
    pub(super) start_miss: Option<&'r StartMiss>,
}

/// How one round ended.
enum Outcome {
    /// No candidate is left.
    Exhausted,
    /// The round named a candidate; `stop` when what remains is consistent with noise.
    Named { stop: bool },
    /// The base re-check improved the base fit by this ΔBIC and no candidate reaches the
    /// threshold against it: the round is done again from the better base.
    Redo(f64),
    /// Nothing was named: the verdict says why.
    Verdict(Verdict),
}

/// The screened candidates of a round.
struct Screened {
    /// Candidates left (effect indices).
    remaining: Vec<usize>,
    /// The current model with its base parameters at their values as given.
    given: Option<ModelState>,
    starts: Vec<CandidateStart>,
    /// Autocorrelation-corrected linearised ΔBIC per candidate.
    corrected: BTreeMap<usize, f64>,
    /// Candidates by screening score, best first.
    order: Vec<(usize, f64)>,
}

/// The current model a round's candidates are compared with: its fit, and whether it is the
/// base model and some output misses the data by more than `FAR_FROM_NOISE` noise levels (there
/// ΔBIC says only that an effect helps, and naming the first effect as the explanation also
/// needs it to explain a share of the misfit).
#[derive(Clone, Copy)]
struct Current<'a> {
    fit: &'a FitOut,
    far: bool,
}

/// A refitted candidate's fit: (effect name, fit, weighted residual over the whole trace).
type Fitted = (String, FitOut, Vec<f64>);

/// Screen, refit and name, round after round, from the base fit `cur`.
pub(super) fn run_rounds<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    inp: &RoundInputs<'_>,
    cur: FitOut,
    cur_full_r: Vec<f64>,
    diagnosis: Diagnosis,
    data: &Data,
    names: &[String],
) -> Result<Rounds, GapError> {
    // Residuals at the noise level and white still get the (cheap) screening: a small effect can
    // hide under the noise in the RMS yet be plain along its own sensitivity direction. Only if
    // no candidate's linearised ΔBIC reaches the threshold are they consistent with noise.
    let looks_like_noise = diagnosis.consistent_with_noise;
    let mut st = Rounds {
        cur,
        cur_full_r,
        named: Vec::new(),
        candidates: Vec::new(),
        diagnosis: vec![diagnosis],
        redone: Vec::new(),
        verdict: None,
        unexplained: None,
    };
    let mut round = 1;
    while round <= inp.cfg.rounds {
        match one_round(ctx, inp, &mut st, round, looks_like_noise, data, names)? {
            Outcome::Exhausted => break,
            Outcome::Named { stop: true } => {
                closing_screen(ctx, inp, &mut st, round + 1);
                break;
            }
            Outcome::Named { stop: false } => round += 1,
            Outcome::Redo(gain) => st.redone.push((round, gain)),
            Outcome::Verdict(v) => {
                st.verdict = Some(v);
                break;
            }
        }
    }
    Ok(st)
}

/// One round from the current model in `st`.
fn one_round<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    inp: &RoundInputs<'_>,
    st: &mut Rounds,
    round: usize,
    looks_like_noise: bool,
    data: &Data,
    names: &[String],
) -> Result<Outcome, GapError> {
    let cfg = inp.cfg;
    let Some(sc) = screen_round(ctx, &st.cur, inp.st0, round) else {
        return Ok(Outcome::Exhausted);
    };
    let best_score = sc
        .corrected
        .values()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    if round == 1 && looks_like_noise && best_score < cfg.min_delta_bic {
        let ranked: Vec<Candidate> = sc
            .order
            .iter()
            .map(|&(e, score)| {
                with_visibility(
                    ctx,
                    &sc,
                    cfg.min_delta_bic,
                    Candidate::screened_only(&ctx.effects[e].name, sc.corrected[&e], score)
                        .hinted(cfg.min_delta_bic),
                )
            })
            .collect();
        let closest = sc
            .corrected
            .iter()
            .max_by(|a, b| a.1.partial_cmp(b.1).unwrap_or(std::cmp::Ordering::Equal))
            .map(|c| ctx.effects[*c.0].name.clone());
        let verdict = Verdict::ConsistentWithNoise {
            closest,
            best_delta_bic: best_score,
            open: left_open(&ranked, cfg.min_delta_bic),
        };
        st.candidates.push(ranked);
        return Ok(Outcome::Verdict(verdict));
    }
    // Residuals at the noise level and white leave nothing a poorly linearised effect could show
    // beyond its linearised evidence. After a named effect, residuals at the noise level in RMS
    // but not white still can: a named friction may mimic most of a strand hysteresis, leaving a
    // small structured rest that the linearisation about it misjudges.
    let at_noise = if round == 1 {
        looks_like_noise
    } else {
        st.diagnosis.last().is_some_and(|d| d.consistent_with_noise)
    };
    let far = st
        .diagnosis
        .last()
        .is_some_and(|d| d.outputs.iter().any(|o| o.rmse_over_noise > FAR_FROM_NOISE));
    let mut top = refit_choice(cfg, &sc, round, at_noise);
    ctx.stage(format!(
        "round {round}: refitting {}",
        effect_names(ctx, &top)
    ));
    let (mut ranked, mut fits) = refit_all(ctx, inp, st, &sc, &top, round);
    // Far from the data the linearised ranking means little, and after a named effect so does a
    // linearisation about a model that already mimics part of the next effect (a friction fitted
    // in place of strand hysteresis), and so does the linearisation of an effect coupled to a
    // base parameter (a radius growth pays off only once the string radius moves with it:
    // linearised ΔBIC −16 on a record whose growth, refitted, is named): when residuals beyond
    // noise remain and no refit reaches the naming threshold, the other candidates (up to
    // `max_refit`; near the data, those whose scan says the data could show them) get theirs.
    if (far || !at_noise) && ranked.iter().all(|c| c.delta_bic < cfg.min_delta_bic) {
        let rest: Vec<(usize, f64)> = sc
            .order
            .iter()
            .take(cfg.max_refit.max(1))
            .filter(|c| !top.iter().any(|t| t.0 == c.0) && (far || could_show(ctx, &sc, c.0)))
            .copied()
            .collect();
        if !rest.is_empty() {
            ctx.stage(format!(
                "round {round}: residuals beyond noise and none named yet; refitting {}",
                effect_names(ctx, &rest)
            ));
            let (r2, f2) = refit_all(ctx, inp, st, &sc, &rest, round);
            ranked.extend(r2);
            fits.extend(f2);
            top.extend(rest);
        }
    }
    if let Some(gain) = recheck_base(ctx, cfg, st, &mut ranked, &fits, round)? {
        return Ok(Outcome::Redo(gain));
    }
    ranked.sort_by(|a, b| {
        b.delta_bic
            .partial_cmp(&a.delta_bic)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    for &(e, score) in sc.order.iter().filter(|c| !top.iter().any(|t| t.0 == c.0)) {
        ranked.push(
            Candidate::screened_only(&ctx.effects[e].name, sc.corrected[&e], score)
                .hinted(cfg.min_delta_bic),
        );
    }
    if ranked.is_empty() {
        return Ok(Outcome::Exhausted);
    }
    let mut ranked: Vec<Candidate> = ranked
        .into_iter()
        .map(|c| with_visibility(ctx, &sc, cfg.min_delta_bic, c))
        .collect();
    // The first effect named is the explanation the report gives; later ones refine a model
    // that already explains a share of the misfit and are judged by their evidence.
    let current = Current {
        fit: &st.cur,
        far: far && st.named.is_empty(),
    };
    match choose(ctx, cfg, &mut ranked, &fits, inp.start_miss, current) {
        Some(i) => {
            let name = ranked[i].effect.clone();
            let pos = fits
                .iter()
                .position(|(s, _, _)| *s == name)
                .expect("fit of the named candidate");
            let (_, f, r) = fits.swap_remove(pos);
            st.candidates.push(ranked);
            // Diagnose what remains. The refit stops early to save simulations; it is polished
            // only for a next round, whose candidates are compared against it. When what
            // remains is already noise, or no round follows, the final fit on the whole trace
            // does that work.
            let d = diagnose_state(ctx, &f.state, data, names)?;
            if d.consistent_with_noise || round >= cfg.rounds {
                st.cur = f;
                st.cur_full_r = r;
                st.named.push(name);
                st.diagnosis.push(d);
                return Ok(Outcome::Named { stop: true });
            }
            adopt(ctx, st, name, f, r, round)?;
            let d = diagnose_state(ctx, &st.cur.state, data, names)?;
            let stop = d.consistent_with_noise;
            st.diagnosis.push(d);
            Ok(Outcome::Named { stop })
        }
        None => {
            let verdict = none_named(cfg, &ranked, &st.named, ctx.n_train >= ctx.n);
            st.unexplained = Some(ranked[0].effect.clone());
            st.candidates.push(ranked);
            Ok(Outcome::Verdict(verdict))
        }
    }
}

/// After the last named effect left residuals at the noise level: the candidates left, screened
/// once more against the final model, as a last round. Their visibility is then what the data
/// show of each beyond the named effects; one the named effects absorbed (correlated signals)
/// may hide there, and the report offers the experiment that would show it. Nothing is refitted
/// or named here: the residuals are noise.
fn closing_screen<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    inp: &RoundInputs<'_>,
    st: &mut Rounds,
    round: usize,
) {
    if !st.diagnosis.last().is_some_and(|d| d.consistent_with_noise) {
        return;
    }
    let Some(sc) = screen_round(ctx, &st.cur, inp.st0, round) else {
        return;
    };
    let ranked: Vec<Candidate> = sc
        .order
        .iter()
        .map(|&(e, score)| {
            let mut c = Candidate::screened_only(&ctx.effects[e].name, sc.corrected[&e], score)
                .hinted(inp.cfg.min_delta_bic);
            c.verdict = CandidateVerdict::ScreenedAgainstFinal {
                named: st.named.clone(),
            };
            with_visibility(ctx, &sc, inp.cfg.min_delta_bic, c)
        })
        .collect();
    st.candidates.push(ranked);
}

/// The names of the effects in `list` (effect index, score), comma-separated.
fn effect_names<S: GridModel + ?Sized>(ctx: &Ctx<'_, S>, list: &[(usize, f64)]) -> String {
    list.iter()
        .map(|(e, _)| ctx.effects[*e].name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Diagnosis of the model `state` over the whole trace.
fn diagnose_state<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    state: &ModelState,
    data: &Data,
    names: &[String],
) -> Result<Diagnosis, GapError> {
    let all = ctx
        .sim
        .simulate(&ctx.settings(state, None, &[]), ctx.n)
        .map_err(GapError::Simulation)?;
    Ok(diagnose(ctx, data, &all, names))
}

/// Scan and screen the candidates not yet named (None: none is left).
fn screen_round<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    cur: &FitOut,
    st0: &ModelState,
    round: usize,
) -> Option<Screened> {
    let effects = &ctx.effects;
    let remaining: Vec<usize> = (0..effects.len())
        .filter(|e| !cur.state.named.contains(e))
        .collect();
    if remaining.is_empty() {
        return None;
    }
    ctx.stage(format!(
        "round {round}: screening {} candidate effect(s)",
        remaining.len()
    ));
    let given = cur.state.with_base(st0);
    let starts = scan_starts(ctx, cur, &remaining, given.as_ref());
    ctx.stage(format!("round {round}: start scan done"));
    for (k, &e) in remaining.iter().enumerate() {
        ctx.stage(format!(
            "visibility of {} over its scan (range fraction: chi-square): {}",
            effects[e].name,
            starts[k]
                .scan
                .iter()
                .map(|x| format!("{:.2}: {:.1}", x.fraction, x.visibility.unwrap_or(f64::NAN)))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let screened = screen(ctx, cur, &remaining, &starts);
    // Ranked by the uncorrected linearised ΔBIC; the autocorrelation-corrected one gates the
    // refits where evidence is required.
    let corrected: BTreeMap<usize, f64> = remaining
        .iter()
        .copied()
        .zip(screened.iter().map(|s| s.1))
        .collect();
    let mut order: Vec<(usize, f64)> = remaining
        .iter()
        .copied()
        .zip(screened.iter().map(|s| s.0))
        .collect();
    ctx.stage(format!("round {round}: screened"));
    order.sort_by(|a, b| b.1.partial_cmp(&a.1).unwrap_or(std::cmp::Ordering::Equal));
    Some(Screened {
        remaining,
        given,
        starts,
        corrected,
        order,
    })
}

/// Whether some scanned setting of effect `e` reaches the naming threshold (unknown: yes): a
/// refit of one that cannot cannot name it.
fn could_show<S: GridModel + ?Sized>(ctx: &Ctx<'_, S>, sc: &Screened, e: usize) -> bool {
    sc.remaining
        .iter()
        .position(|&c| c == e)
        .and_then(|k| max_visibility(&sc.starts[k].scan))
        .is_none_or(|v| v >= ctx.visibility_needed(e))
}

/// The largest visibility over a candidate's scan (None: no setting has one).
fn max_visibility(scan: &[VisibilityPoint]) -> Option<f64> {
    scan.iter().filter_map(|x| x.visibility).reduce(f64::max)
}

/// The candidate with its visibility over the scan (how much the data could show of it), and
/// for a refit that reached the naming threshold at least what that refit showed
/// ([`refit_evidence`]).
fn with_visibility<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    sc: &Screened,
    min_delta_bic: f64,
    mut c: Candidate,
) -> Candidate {
    if let Some(k) = sc
        .remaining
        .iter()
        .position(|&e| ctx.effects[e].name == c.effect)
    {
        let scan = &sc.starts[k].scan;
        let needed = ctx.visibility_needed(sc.remaining[k]);
        c.visibility = max_visibility(scan);
        c.visibility_needed = needed;
        c.detectable_from = scan
            .iter()
            .find(|x| x.visibility.is_some_and(|v| v >= needed))
            .map(|x| x.parameters.clone());
        c.visibility_scan = scan.clone();
        let shown = refit_evidence(&c, needed, min_delta_bic);
        if let Some(shown) = shown {
            c.visibility = Some(c.visibility.map_or(shown, |v| v.max(shown)));
            if c.detectable_from.is_none() {
                let at = c.parameters.iter().map(|(k, e)| (k.clone(), e.value));
                c.detectable_from = Some(at.collect());
            }
        }
    }
    c
}

/// What a refit that reached the naming threshold showed of its effect, on the scale of
/// `visibility_needed`: ΔBIC plus the parameters' penalty (`needed − min ΔBIC`), at least
/// `needed`. The scan linearises about the current fit, where an effect may be inert (a
/// friction level on its bound, a dead zone of no width) and look invisible; the refit's
/// evidence is measured where the effect acts, so it bounds the visibility from below, and the
/// refitted setting is one the data show. None for a candidate not refitted or short of the
/// threshold.
fn refit_evidence(c: &Candidate, needed: f64, min_delta_bic: f64) -> Option<f64> {
    (c.refit && c.delta_bic >= min_delta_bic).then_some(c.delta_bic + (needed - min_delta_bic))
}

/// Which screened candidates are refitted. Whatever the linearised evidence (a dead zone or
/// backlash is poorly linearised, and an effect coupled to a base parameter can show its gain
/// only once both move): unless the residuals are at the noise level (`at_noise`: round 1,
/// consistent with noise; later rounds, every output's RMS within `NOISE_RMS_RATIO` of its
/// noise), the best two, and up to `max_refit` of those scoring at least `REFIT_SCORE_FRACTION`
/// of the best (round 1; later rounds, two at most); beyond that, candidates whose linearised
/// evidence reaches the naming threshold.
fn refit_choice(cfg: &Config, sc: &Screened, round: usize, at_noise: bool) -> Vec<(usize, f64)> {
    let quota = if round == 1 {
        cfg.max_refit
    } else {
        LATER_ROUND_REFITS
    };
    let best = sc.order.first().map_or(0.0, |c| c.1);
    sc.order
        .iter()
        .enumerate()
        .filter(|(i, (e, score))| {
            let close = *i < ALWAYS_REFIT || *score >= REFIT_SCORE_FRACTION * best;
            *i < cfg.max_refit.max(1)
                && ((!at_noise && *i < quota && close) || sc.corrected[e] >= cfg.min_delta_bic)
        })
        .map(|(_, c)| *c)
        .collect()
}

/// Refit the chosen candidates (in parallel), then restart from their effect's profile those
/// that fall short when none reaches the naming threshold, else the best one.
fn refit_all<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    inp: &RoundInputs<'_>,
    st: &Rounds,
    sc: &Screened,
    top: &[(usize, f64)],
    round: usize,
) -> (Vec<Candidate>, Vec<Fitted>) {
    type Refit = Result<(Candidate, FitOut, Vec<f64>), SimError>;
    let (cur, cur_full_r) = (&st.cur, &st.cur_full_r);
    let k_of = |e: usize| sc.remaining.iter().position(|&c| c == e);
    let refits: Vec<(usize, f64, Refit)> = top
        .par_iter()
        .enumerate()
        .map(|(i, &(e, score))| {
            let alt = (round == 1 && i == 0).then_some(inp.st0);
            let k = k_of(e).expect("refitted candidates are screened ones");
            (
                e,
                score,
                refit(ctx, cur, e, score, cur_full_r, alt, &sc.starts[k]),
            )
        })
        .collect();
    let mut ranked: Vec<Candidate> = Vec::new();
    let mut fits: Vec<Fitted> = Vec::new();
    for (e, score, res) in refits {
        match res {
            Ok((c, f, r)) => {
                fits.push((c.effect.clone(), f, r));
                ranked.push(c)
            }
            Err(m) => ranked.push(Candidate {
                refit: true,
                verdict: CandidateVerdict::RefitFailed { cause: m },
                ..Candidate::screened_only(&ctx.effects[e].name, f64::NEG_INFINITY, score)
            }),
        }
    }
    // Profile restarts (see `profile_restart`): when no refit reaches the naming threshold,
    // every refitted candidate that falls short of it although the data could show it; when one
    // does, the best one. A refit stops where a step gains less than its stopping tolerance,
    // which along a bent valley can be anywhere, so whether the profile ran, and the named
    // estimate, must not turn on the last bits of the data. Either way, only candidates that
    // predict the held-out end no worse than the current model, within one standard deviation
    // of a chi-square over the held-out samples, √(2 N_h) (or nothing is held out); one that
    // predicts clearly worse is not worth the simulations.
    let best = best_refit_delta_bic(&ranked);
    let reached = best >= inp.cfg.min_delta_bic;
    {
        let n_held = (ctx.out_idx.len() * (ctx.n - ctx.n_train)) as f64;
        let eligible: Vec<usize> = (0..ranked.len())
            .filter(|&i| {
                let c = &ranked[i];
                c.refit
                    && c.delta_bic.is_finite()
                    && (!reached || c.delta_bic == best)
                    && match (c.holdout_sse_with, c.holdout_sse_without) {
                        (Some(with), Some(without)) => with <= without + (2.0 * n_held).sqrt(),
                        _ => true,
                    }
            })
            .collect();
        let restarted: Vec<(usize, Refit)> = eligible
            .par_iter()
            .filter_map(|&i| {
                let c = &ranked[i];
                let e = ctx.effects.iter().position(|x| x.name == c.effect)?;
                let k = k_of(e)?;
                let (_, f, _) = fits.iter().find(|x| x.0 == c.effect)?;
                let g = profile_restart(ctx, cur, e, f, &sc.starts[k].scan, sc.given.as_ref())?;
                Some((i, assess(ctx, cur, e, c.score, cur_full_r, g)))
            })
            .collect();
        for (i, res) in restarted {
            if let Ok((mut c, f, r)) = res {
                c.profiled = true;
                if let Some(x) = fits.iter_mut().find(|x| x.0 == c.effect) {
                    *x = (c.effect.clone(), f, r);
                }
                ranked[i] = c;
            }
        }
    }
    (ranked, fits)
}

/// Base re-check: a candidate refit also re-optimises the base parameters from a new start, and
/// a gain that the base model alone reaches from the candidate's base values is the base fit's,
/// not the effect's. Refit the base model from the best candidate's base values; if it lowers
/// the base sum, it becomes the current model and every candidate's ΔBIC and held-out comparison
/// are taken against it. Only needed when some candidate reaches the naming threshold. Returns
/// the base's gain when the round must be done again from it: the candidates were refitted
/// from a base this much worse, and none of them still reaches the threshold against the
/// better one (once per round).
fn recheck_base<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    cfg: &Config,
    st: &mut Rounds,
    ranked: &mut [Candidate],
    fits: &[Fitted],
    round: usize,
) -> Result<Option<f64>, GapError> {
    let kout = ctx.out_idx.len();
    let best_refit = best_refit_delta_bic(ranked);
    let delta_of = |name: &str| {
        ranked
            .iter()
            .find(|c| c.effect == name)
            .map_or(f64::NEG_INFINITY, |c| c.delta_bic)
    };
    let Some((_, f, _)) = fits
        .iter()
        .filter(|_| best_refit >= cfg.min_delta_bic)
        .max_by(|a, b| delta_of(&a.0).total_cmp(&delta_of(&b.0)))
    else {
        return Ok(None);
    };
    let nb = st.cur.state.idx.len();
    let from = st.cur.state.with_values(f.state.val[..nb].to_vec());
    ctx.stage(format!("round {round}: base re-check"));
    let limits =
        Limits::new(BASE_RECHECK_ITERATIONS, BASE_RECHECK_REL_TOL).without_final_jacobian();
    let Ok(mut b2) = fit_state(ctx, &from, None, &[], ctx.n_train, limits) else {
        return Ok(None);
    };
    if b2.fit.sse >= st.cur.fit.sse - LM_ABS_TOL {
        return Ok(None);
    }
    ensure_jacobian(ctx, &mut b2, ctx.n_train);
    let y = ctx
        .measured_outputs(&ctx.settings(&b2.state, None, &[]), ctx.n)
        .map_err(GapError::Simulation)?;
    let base_gain = delta_bic(&st.cur.fit.residuals, &b2.fit.residuals, kout, 0);
    st.cur = b2;
    st.cur_full_r = ctx.residual(&y, ctx.n);
    let without = holdout_sse(&st.cur_full_r, kout, ctx.n, ctx.n_train);
    for c in ranked.iter_mut().filter(|c| c.refit) {
        if let Some((_, fc, _)) = fits.iter().find(|x| x.0 == c.effect) {
            let extra = fc.state.idx.len() - nb;
            c.delta_bic = delta_bic(&st.cur.fit.residuals, &fc.fit.residuals, kout, extra);
            c.holdout_sse_without = without;
        }
    }
    let redo = base_gain >= cfg.min_delta_bic
        && best_refit_delta_bic(ranked) < cfg.min_delta_bic
        && !st.redone.iter().any(|r| r.0 == round);
    if redo {
        ctx.stage(format!(
            "round {round}: the base re-check improved the base fit by ΔBIC = {base_gain:.1}; the round is done again from it"
        ));
    }
    Ok(redo.then_some(base_gain))
}

/// Check every refitted candidate in ΔBIC order; the first passing all criteria is named (a
/// candidate that absorbs part of a different missing effect may top the BIC ranking yet fail on
/// the held-out part; and on a base model far from the data, one that bends a little of a
/// large misfit away passes ΔBIC without being what is missing: it must cover
/// `MIN_EXPLAINED_SHARE` of the way from the current model to the noise). Writes each checked
/// candidate's verdict; returns the named one's index.
fn choose<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    cfg: &Config,
    ranked: &mut [Candidate],
    fits: &[Fitted],
    start_miss: Option<&StartMiss>,
    cur: Current<'_>,
) -> Option<usize> {
    let mut chosen = None;
    for (i, c) in ranked.iter_mut().enumerate() {
        if !c.refit {
            continue;
        }
        let mut why = shortfalls(c, cfg.min_delta_bic, ctx.n_train >= ctx.n);
        let fit = fits.iter().find(|x| x.0 == c.effect);
        if let (Some(miss), Some((_, _, r))) = (start_miss, fit) {
            if !reproduces_start(ctx, miss, r, true) {
                why.push(Shortfall::StartNotReproduced);
            }
        }
        if let Some((_, f, _)) = fit {
            c.explained_share = explained_share(ctx, &cur.fit.fit.residuals, &f.fit.residuals);
            match c.explained_share {
                Some(share) if cur.far && share < MIN_EXPLAINED_SHARE => {
                    why.push(Shortfall::ExplainsLittle {
                        share,
                        min_share: MIN_EXPLAINED_SHARE,
                    })
                }
                _ => {}
            }
        }
        if why.is_empty() {
            c.named = true;
            c.verdict = CandidateVerdict::Named {
                delta_bic: c.delta_bic,
                min_delta_bic: cfg.min_delta_bic,
            };
            chosen = Some(i);
            break;
        }
        c.inconclusive = c.delta_bic > 0.0 && c.delta_bic < cfg.min_delta_bic;
        c.verdict = CandidateVerdict::NotNamed {
            shortfalls: why,
            unrevealable: (!c.detectable()).then(|| c.reach()),
        };
    }
    for c in ranked
        .iter_mut()
        .filter(|c| c.refit && matches!(c.verdict, CandidateVerdict::Unchecked))
    {
        c.verdict = CandidateVerdict::NotConsidered;
    }
    chosen
}

/// Make the named candidate's fit `f` (full-trace residual `r`) the current model, after
/// polishing it (the candidate refits stop early to save simulations; a failed polish keeps
/// the refit).
fn adopt<S: GridModel + ?Sized>(
    ctx: &Ctx<'_, S>,
    st: &mut Rounds,
    name: String,
    f: FitOut,
    r: Vec<f64>,
    round: usize,
) -> Result<(), GapError> {
    ctx.stage(format!("round {round}: polishing the fit with {name}"));
    let limits = POLISH_LIMITS.without_final_jacobian();
    let (f, r) = match fit_state(ctx, &f.state, None, &[], ctx.n_train, limits) {
        Ok(mut p) if p.fit.sse <= f.fit.sse => {
            ensure_jacobian(ctx, &mut p, ctx.n_train);
            let y = ctx
                .measured_outputs(&ctx.settings(&p.state, None, &[]), ctx.n)
                .map_err(GapError::Simulation)?;
            let r = ctx.residual(&y, ctx.n);
            (p, r)
        }
        _ => (f, r),
    };
    ctx.stage(format!(
        "round {round}: polished, {} simulations",
        f.fit.evaluations
    ));
    st.cur = f;
    st.cur_full_r = r;
    st.named.push(name);
    Ok(())
}

/// The verdict of a round that named nothing (`no_holdout`: nothing is held out).
fn none_named(cfg: &Config, ranked: &[Candidate], named: &[String], no_holdout: bool) -> Verdict {
    let closest = &ranked[0];
    let why = if closest.refit {
        let shortfalls = match &closest.verdict {
            CandidateVerdict::NotNamed { shortfalls, .. } => shortfalls.clone(),
            _ => shortfalls(closest, cfg.min_delta_bic, no_holdout),
        };
        ClosestShortfall::Refitted { shortfalls }
    } else {
        ClosestShortfall::NotRefitted {
            delta_bic: closest.delta_bic,
            min_delta_bic: cfg.min_delta_bic,
        }
    };
    Verdict::NothingFurther {
        named: named.to_vec(),
        closest: closest.effect.clone(),
        why,
        open: left_open(ranked, cfg.min_delta_bic),
    }
}

#[cfg(test)]
mod tests {
    use super::refit_evidence;
    use crate::workflow::Candidate;

    #[test]
    fn a_refit_at_the_threshold_shows_at_least_what_naming_needs() {
        // needed = 10 + 1 ln(1000) = 16.9: ΔBIC 217 shows 223.9; ΔBIC 9.9 shows nothing
        let needed = 10.0 + libm::log(1000.0);
        let mut c = Candidate::screened_only("friction", 217.0, 200.0);
        assert_eq!(refit_evidence(&c, needed, 10.0), None, "not refitted");
        c.refit = true;
        let shown = refit_evidence(&c, needed, 10.0).unwrap();
        assert!((shown - (217.0 + libm::log(1000.0))).abs() < 1e-12);
        c.delta_bic = 10.0;
        assert!(refit_evidence(&c, needed, 10.0).unwrap() >= needed);
        c.delta_bic = 9.9;
        assert_eq!(refit_evidence(&c, needed, 10.0), None);
    }
}
