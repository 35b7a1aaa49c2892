//! The bounded records the plots of a run are drawn from, and their state in a checkpoint.
//!
//! [`PlotTrace`] keeps the nodes of a trajectory (time, q, p, the relative energy error, a
//! constrained run's residual and the time since the previous node); [`SectionPoints`] keeps
//! the points of the Poincaré sections. Memory is bounded whatever the length of the run:
//! when a record holds its limit, every other entry is dropped and from then on only every
//! 2nd, 4th, … offered entry is taken ([`Decimation`]); a trajectory's last node is always
//! kept. A plot draws at most 5 000 points per line anyway (`plot::thin`), so for runs within
//! the limit the plots are unchanged.
//!
//! Both records turn into words ([`PlotTrace::words`], [`SectionPoints::words`]) and back,
//! bit for bit, so that a run with plots stopped at a checkpoint and resumed draws the plots
//! of an uninterrupted run ([`crate::resume`]).

/// Which entries a record holds: those whose index is a multiple of `stride`, and the last;
/// when `limit` are held, every other one goes and the stride doubles.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Decimation {
    seen: usize,
    stride: usize,
    limit: usize,
}

impl Decimation {
    fn new(limit: usize) -> Self {
        Decimation {
            seen: 0,
            stride: 1,
            limit: limit.max(2),
        }
    }

    /// For the next entry (`last`: the run's final one), with `held` entries held: whether to
    /// halve those first, and whether to keep this one.
    fn offer(&mut self, held: usize, last: bool) -> (bool, bool) {
        let index = self.seen;
        self.seen += 1;
        if !(last || index.is_multiple_of(self.stride)) {
            return (false, false);
        }
        if held >= self.limit {
            self.stride *= 2;
            return (true, last || index.is_multiple_of(self.stride));
        }
        (false, true)
    }

    fn words(&self) -> [u64; 3] {
        [self.seen as u64, self.stride as u64, self.limit as u64]
    }

    /// From [`Decimation::words`]; None unless the stride is a power of two and the limit
    /// the one expected.
    fn from_words(w: [u64; 3], limit: usize) -> Option<Self> {
        let d = Decimation {
            seen: usize::try_from(w[0]).ok()?,
            stride: usize::try_from(w[1]).ok()?,
            limit: usize::try_from(w[2]).ok()?,
        };
        (d.stride.is_power_of_two() && d.limit == limit.max(2)).then_some(d)
    }
}

/// Most values (times, coordinates, momenta, energies, steps) a [`PlotTrace`] keeps.
const MAX_VALUES: usize = 1 << 22;

/// Most nodes a [`PlotTrace`] keeps for a system with n coordinates: 65 536, fewer when a
/// node's 2n + 3 values would take more than `MAX_VALUES` (2²²) in all, and at least 16.
pub fn max_nodes(n: usize) -> usize {
    (MAX_VALUES / (2 * n + 3)).clamp(16, 1 << 16)
}

/// Most points a [`SectionPoints`] keeps (about 3 MB).
pub const MAX_SECTION_POINTS: usize = 1 << 17;

/// Keeps the chunks of `width` values of `v` at even positions (0, 2, 4, …).
fn keep_even<T: Copy>(v: &mut Vec<T>, width: usize) {
    let chunks = v.len() / width.max(1);
    for c in (0..chunks).step_by(2) {
        let to = c / 2 * width;
        v.copy_within(c * width..(c + 1) * width, to);
    }
    v.truncate(chunks.div_ceil(2) * width);
}

/// The nodes of a trajectory kept for its plots (the module documentation).
///
/// # Example
///
/// ```
/// use femvi_cli::record::{PlotTrace, TraceNode};
/// let mut trace = PlotTrace::new(1);
/// for k in 0..3 {
///     let t = 0.5 * k as f64;
///     trace.offer(TraceNode { t, q: &[t.cos()], p: &[-t.sin()], rel_energy: 0.0, residual: None }, k == 2);
/// }
/// assert_eq!(trace.t, [0.0, 0.5, 1.0]);
/// assert!(trace.steps[0].is_nan() && trace.steps[2] == 0.5);
/// // Its words give it back, bit for bit.
/// assert_eq!(PlotTrace::from_words(1, &trace.words()).unwrap().words(), trace.words());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct PlotTrace {
    n: usize,
    /// Times of the nodes held.
    pub t: Vec<f64>,
    /// Their coordinates, node after node.
    pub q: Vec<f64>,
    /// Their momenta, node after node.
    pub p: Vec<f64>,
    /// Their relative energy errors.
    pub rel_energy: Vec<f64>,
    /// A constrained run's max |g(q)| per node held (empty otherwise).
    pub residual: Vec<f64>,
    /// Per node held: the time since the node offered before it (NaN for the first).
    pub steps: Vec<f64>,
    /// The node offered last, held or not.
    previous: Option<f64>,
    decimation: Decimation,
}

/// One node offered to a [`PlotTrace`].
#[derive(Debug, Clone, Copy)]
pub struct TraceNode<'a> {
    /// Its time.
    pub t: f64,
    /// Its coordinates.
    pub q: &'a [f64],
    /// Its momenta.
    pub p: &'a [f64],
    /// Its relative energy error.
    pub rel_energy: f64,
    /// A constrained run's max |g(q)| there.
    pub residual: Option<f64>,
}

/// Words of the fixed part of [`PlotTrace::words`]: n, the decimation (3), whether there is a
/// previous node and its time, the nodes held and whether residuals are held.
const TRACE_HEAD: usize = 8;

impl PlotTrace {
    /// An empty trace of a system with `n` coordinates, holding at most [`max_nodes`]`(n)`.
    pub fn new(n: usize) -> Self {
        Self::with_limit(n, max_nodes(n))
    }

    fn with_limit(n: usize, limit: usize) -> Self {
        PlotTrace {
            n,
            t: vec![],
            q: vec![],
            p: vec![],
            rel_energy: vec![],
            residual: vec![],
            steps: vec![],
            previous: None,
            decimation: Decimation::new(limit),
        }
    }

    /// Offers the next node (`last`: the run's final one).
    pub fn offer(&mut self, node: TraceNode<'_>, last: bool) {
        let step = self.previous.map_or(f64::NAN, |previous| node.t - previous);
        self.previous = Some(node.t);
        let (halve, keep) = self.decimation.offer(self.t.len(), last);
        if halve {
            let n = self.n;
            keep_even(&mut self.t, 1);
            keep_even(&mut self.q, n);
            keep_even(&mut self.p, n);
            keep_even(&mut self.rel_energy, 1);
            keep_even(&mut self.residual, 1);
            keep_even(&mut self.steps, 1);
        }
        if !keep {
            return;
        }
        self.steps.push(step);
        self.t.push(node.t);
        self.q.extend_from_slice(node.q);
        self.p.extend_from_slice(node.p);
        self.rel_energy.push(node.rel_energy);
        if let Some(g) = node.residual {
            self.residual.push(g);
        }
    }

    /// The whole state as words (f64 as their bits), for a checkpoint.
    pub fn words(&self) -> Vec<u64> {
        let held = self.t.len();
        let mut w = Vec::with_capacity(TRACE_HEAD + held * (2 * self.n + 4));
        w.push(self.n as u64);
        w.extend(self.decimation.words());
        w.push(u64::from(self.previous.is_some()));
        w.push(self.previous.unwrap_or(0.0).to_bits());
        w.push(held as u64);
        w.push(u64::from(!self.residual.is_empty()));
        for v in [&self.t, &self.q, &self.p, &self.rel_energy, &self.residual, &self.steps] {
            w.extend(v.iter().map(|x| x.to_bits()));
        }
        w
    }

    /// The trace [`PlotTrace::words`] gave, for a system with `n` coordinates.
    ///
    /// # Errors
    /// The words are not those of such a trace.
    pub fn from_words(n: usize, w: &[u64]) -> Result<Self, String> {
        Self::from_words_limit(n, w, max_nodes(n))
    }

    fn from_words_limit(n: usize, w: &[u64], limit: usize) -> Result<Self, String> {
        let bad = || "the checkpoint's plot state does not fit this problem".to_string();
        let head: [u64; TRACE_HEAD] = w.get(..TRACE_HEAD).and_then(|h| h.try_into().ok()).ok_or_else(bad)?;
        let decimation = Decimation::from_words([head[1], head[2], head[3]], limit).ok_or_else(bad)?;
        let held = usize::try_from(head[6]).map_err(|_| bad())?;
        let with_residual = head[7] == 1;
        if head[0] != n as u64 || held > decimation.limit || head[4] > 1 || head[7] > 1 {
            return Err(bad());
        }
        let lengths = [
            held,
            held * n,
            held * n,
            held,
            if with_residual { held } else { 0 },
            held,
        ];
        if w.len() != TRACE_HEAD + lengths.iter().sum::<usize>() {
            return Err(bad());
        }
        let mut rest = &w[TRACE_HEAD..];
        let mut take = |len: usize| {
            let (a, b) = rest.split_at(len);
            rest = b;
            a.iter().map(|x| f64::from_bits(*x)).collect::<Vec<f64>>()
        };
        let mut trace = Self::with_limit(n, limit);
        trace.t = take(lengths[0]);
        trace.q = take(lengths[1]);
        trace.p = take(lengths[2]);
        trace.rel_energy = take(lengths[3]);
        trace.residual = take(lengths[4]);
        trace.steps = take(lengths[5]);
        trace.previous = (head[4] == 1).then(|| f64::from_bits(head[5]));
        trace.decimation = decimation;
        Ok(trace)
    }
}

/// The points of the Poincaré sections kept for their plots: per event located, its index
/// and (q₁, p₁) there, at most [`MAX_SECTION_POINTS`].
#[derive(Debug, Clone, PartialEq)]
pub struct SectionPoints {
    /// (event index, q₁, p₁) of the points held.
    pub points: Vec<(usize, f64, f64)>,
    decimation: Decimation,
}

impl Default for SectionPoints {
    fn default() -> Self {
        Self::with_limit(MAX_SECTION_POINTS)
    }
}

impl SectionPoints {
    fn with_limit(limit: usize) -> Self {
        SectionPoints {
            points: vec![],
            decimation: Decimation::new(limit),
        }
    }

    /// Offers the next event located: its index and (q₁, p₁).
    pub fn offer(&mut self, event: usize, q1: f64, p1: f64) {
        let (halve, keep) = self.decimation.offer(self.points.len(), false);
        if halve {
            keep_even(&mut self.points, 1);
        }
        if keep {
            self.points.push((event, q1, p1));
        }
    }

    /// The whole state as words, for a checkpoint.
    pub fn words(&self) -> Vec<u64> {
        let mut w = self.decimation.words().to_vec();
        for &(e, q, p) in &self.points {
            w.extend([e as u64, q.to_bits(), p.to_bits()]);
        }
        w
    }

    /// The points [`SectionPoints::words`] gave.
    ///
    /// # Errors
    /// The words are not those of such points.
    pub fn from_words(w: &[u64]) -> Result<Self, String> {
        Self::from_words_limit(w, MAX_SECTION_POINTS)
    }

    fn from_words_limit(w: &[u64], limit: usize) -> Result<Self, String> {
        let bad = || "the checkpoint's Poincaré points do not fit this problem".to_string();
        let head: [u64; 3] = w.get(..3).and_then(|h| h.try_into().ok()).ok_or_else(bad)?;
        let decimation = Decimation::from_words(head, limit).ok_or_else(bad)?;
        let body = &w[3..];
        if !body.len().is_multiple_of(3) || body.len() / 3 > decimation.limit {
            return Err(bad());
        }
        let points = body
            .chunks_exact(3)
            .map(|c| {
                Ok((
                    usize::try_from(c[0]).map_err(|_| bad())?,
                    f64::from_bits(c[1]),
                    f64::from_bits(c[2]),
                ))
            })
            .collect::<Result<_, String>>()?;
        Ok(SectionPoints { points, decimation })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Entries offered one by one: never more than the limit held, evenly spaced by the final
    /// stride from entry 0, and the last one always held.
    #[test]
    fn decimation_holds_a_bounded_evenly_spaced_subset_and_the_last_entry() {
        for (total, limit) in [
            (1usize, 16usize),
            (10, 16),
            (16, 16),
            (17, 16),
            (1000, 16),
            (100_003, 1000),
        ] {
            let mut d = Decimation::new(limit);
            let mut held: Vec<usize> = vec![];
            for i in 0..total {
                let (halve, keep) = d.offer(held.len(), i + 1 == total);
                if halve {
                    keep_even(&mut held, 1);
                }
                if keep {
                    held.push(i);
                }
                assert!(held.len() <= limit, "{total} {limit}: {} held", held.len());
            }
            assert_eq!(held.last(), Some(&(total - 1)));
            let body = &held[..held.len() - 1];
            for (j, &i) in body.iter().enumerate() {
                assert_eq!(i, j * d.stride, "{total} {limit}");
            }
            // Not thinned more than needed: at least a quarter of the limit held.
            assert!(held.len() >= (limit / 4).min(total), "{total} {limit}: {}", held.len());
        }
    }

    #[test]
    fn keep_even_keeps_chunks_at_even_positions() {
        let mut v: Vec<f64> = (0..10).map(f64::from).collect();
        keep_even(&mut v, 2);
        assert_eq!(v, [0.0, 1.0, 4.0, 5.0, 8.0, 9.0]);
        let mut w = vec![1, 2, 3];
        keep_even(&mut w, 1);
        assert_eq!(w, [1, 3]);
    }

    #[test]
    fn node_limits_are_bounded() {
        assert_eq!(max_nodes(1), 1 << 16);
        assert!(max_nodes(1000) * 2003 <= MAX_VALUES);
        assert!(max_nodes(100_000) * 200_003 <= MAX_VALUES);
        assert_eq!(max_nodes(10_000_000), 16);
    }

    /// A node of a made-up trajectory of two coordinates (irrational values: every bit counts).
    fn offer_node(trace: &mut PlotTrace, k: usize, total: usize, residual: bool) {
        let t = 0.1 * k as f64 + (k as f64).sqrt() * 1e-3;
        let q = [t.sin(), (2.0 * t).cos()];
        let p = [t.cos(), -(2.0 * t).sin()];
        let node = TraceNode {
            t,
            q: &q,
            p: &p,
            rel_energy: 1e-9 * t.exp().fract(),
            residual: residual.then_some(1e-15 * t),
        };
        trace.offer(node, k + 1 == total);
    }

    /// A trace saved to words at any node and restored continues as the uninterrupted one,
    /// bit for bit, through decimations (limit 16, 300 nodes: four halvings).
    #[test]
    fn a_trace_restored_from_its_words_continues_bit_for_bit() {
        for residual in [false, true] {
            let total = 300;
            let mut whole = PlotTrace::with_limit(2, 16);
            for k in 0..total {
                offer_node(&mut whole, k, total, residual);
            }
            assert!(whole.decimation.stride >= 16 && whole.t.len() <= 16);
            for cut in [0, 1, 15, 16, 17, 100, 255, 299] {
                let mut first = PlotTrace::with_limit(2, 16);
                for k in 0..=cut {
                    offer_node(&mut first, k, total, residual);
                }
                let mut resumed = PlotTrace::from_words_limit(2, &first.words(), 16).unwrap();
                assert_eq!(resumed.words(), first.words(), "cut {cut}");
                for k in cut + 1..total {
                    offer_node(&mut resumed, k, total, residual);
                }
                assert_eq!(resumed.words(), whole.words(), "cut {cut}, residual {residual}");
            }
        }
    }

    #[test]
    fn words_of_another_shape_are_refused() {
        let mut trace = PlotTrace::with_limit(2, 16);
        for k in 0..20 {
            offer_node(&mut trace, k, 20, false);
        }
        let w = trace.words();
        assert!(PlotTrace::from_words_limit(3, &w, 16).is_err());
        assert!(PlotTrace::from_words_limit(2, &w[..w.len() - 1], 16).is_err());
        assert!(PlotTrace::from_words_limit(2, &w, 32).is_err());
        assert!(PlotTrace::from_words_limit(2, &[], 16).is_err());
        let mut huge = w.clone();
        huge[6] = u64::MAX;
        assert!(PlotTrace::from_words_limit(2, &huge, 16).is_err());
        assert!(SectionPoints::from_words(&[1, 3, 8]).is_err());
        assert!(SectionPoints::from_words(&[0, 1, MAX_SECTION_POINTS as u64, 0, 0]).is_err());
    }

    #[test]
    fn section_points_are_bounded_and_restored_bit_for_bit() {
        let offer = |s: &mut SectionPoints, i: usize| s.offer(i % 3, (i as f64).sqrt(), -(i as f64).ln_1p());
        let mut whole = SectionPoints::with_limit(8);
        for i in 0..100 {
            offer(&mut whole, i);
            assert!(whole.points.len() <= 8);
        }
        let mut first = SectionPoints::with_limit(8);
        for i in 0..41 {
            offer(&mut first, i);
        }
        let mut resumed = SectionPoints::from_words_limit(&first.words(), 8).unwrap();
        for i in 41..100 {
            offer(&mut resumed, i);
        }
        assert_eq!(resumed, whole);
        // Evenly spaced from the first event.
        let stride = whole.decimation.stride;
        for (j, &(e, q, _)) in whole.points.iter().enumerate() {
            assert_eq!((e, q), ((j * stride) % 3, ((j * stride) as f64).sqrt()));
        }
    }
}
