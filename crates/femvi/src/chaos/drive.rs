//! The loop shared by every chaos run: step, carry the tangent vectors through the step's
//! tangent map, accumulate MEGNO, FLI, the largest exponent and the spectrum
//! (`accumulate.rs`). The run behind it — a plain [`crate::step::Integrator`], a forced run
//! ([`crate::forces`]) or a constrained run on the manifold ([`crate::constraints`]) — is a
//! [`TangentRun`]: it takes the steps and carries vectors of its tangent dimension d (2n, or
//! 2(n − m) on a constraint manifold).

use super::accumulate::{norm, Growth};
use super::orthonormal::orthonormalise;
use super::{ChaosOptions, ChaosReport, ChaosSample, FinalNode};
use crate::error::Result;

/// A run whose steps carry tangent vectors.
pub(crate) trait TangentRun {
    /// Takes the next step: Ok(false) at the end of the grid.
    fn advance(&mut self) -> Result<bool>;
    /// Carries `vectors` (one vector of length d, then k more, column-major, possibly none:
    /// one buffer, so that a route with a per-step setup makes it once and nothing is copied)
    /// through the last step's tangent map.
    fn carry(&mut self, vectors: &mut [f64]) -> Result<()>;
    /// Time at the current node.
    fn time(&self) -> f64;
    /// Length of the last step (0 before the first).
    fn last_step(&self) -> f64;
    /// The current node (t, q, p).
    fn node(&self) -> FinalNode;
}

/// Runs `run` to its end from the unit vector `u` (length d), with the spectrum's d vectors
/// if asked (starting as the identity), and accumulates the indicators (module docs of
/// [`super`]); time is counted from the current node.
pub(crate) fn drive<R: TangentRun>(run: &mut R, u: Vec<f64>, chaos: &ChaosOptions) -> ChaosReport {
    let d = u.len();
    let k = if chaos.spectrum { d } else { 0 };
    // u, then the spectrum's vectors, which start as the identity (column-major).
    let mut vectors = u;
    vectors.extend((0..k * d).map(|i| if i % d == i / d { 1.0 } else { 0.0 }));
    let (mut logs, mut sums) = (vec![0.0; k], vec![0.0; k]);
    let (t0, mut growth) = (run.time(), Growth::new());
    // The spectrum counts growth from here (after the transient).
    let mut counted_from = t0;
    let (mut steps, mut series, mut error) = (0, vec![], None);
    let sample = |g: &Growth, t: f64| ChaosSample {
        t,
        megno: g.megno,
        mean_megno: g.mean_megno,
        fli: g.fli,
        lyapunov: g.log_norm / (t - t0),
    };
    loop {
        match run.advance() {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => {
                error = Some(e);
                break;
            }
        }
        if let Err(e) = run.carry(&mut vectors) {
            error = Some(e);
            break;
        }
        let (u, w) = vectors.split_at_mut(d);
        steps += 1;
        let (t, h) = (run.time(), run.last_step());
        let len = norm(u);
        u.iter_mut().for_each(|x| *x /= len);
        growth.step(len.ln(), h, t - t0);
        if k > 0 && steps % chaos.renormalize_every.max(1) == 0 {
            orthonormalise(w, d, &mut logs);
            if t - t0 > chaos.spectrum_transient {
                sums.iter_mut().zip(&logs).for_each(|(s, l)| *s += l);
            } else {
                counted_from = t;
            }
        }
        if chaos.record_every > 0 && steps % chaos.record_every == 0 {
            series.push(sample(&growth, t));
        }
    }
    let t = run.time();
    if k > 0 && steps % chaos.renormalize_every.max(1) != 0 {
        orthonormalise(&mut vectors[d..], d, &mut logs);
        sums.iter_mut().zip(&logs).for_each(|(s, l)| *s += l);
    }
    ChaosReport {
        steps,
        last: sample(&growth, t),
        spectrum: (k > 0).then(|| sums.iter().map(|s| s / (t - counted_from)).collect()),
        series,
        error,
        final_node: run.node(),
    }
}
