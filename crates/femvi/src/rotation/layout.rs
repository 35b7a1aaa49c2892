//! Which coordinates of a Lagrangian on Rⁿ are rotations: blocks of nine consecutive
//! coordinates holding the entries of R ∈ SO(3) row-major (R₁₁, R₁₂, …, R₃₃), the others
//! ordinary coordinates. The Lie-group element (`action.rs`) varies a rotation block in the
//! algebra, R = R_k exp(ξ̂), and an ordinary coordinate as a point of R; the unknowns of a
//! step are grouped in *slots*: three per rotation, then one per ordinary coordinate.

use crate::error::{invalid, Result};

/// The rotation blocks of a configuration vector.
///
/// # Example
/// ```
/// use femvi::rotation::Rotations;
/// // A body's rotation (coordinates 0..9) and a slider x (coordinate 9).
/// let layout = Rotations::new(10, &[0])?;
/// assert_eq!((layout.count(), layout.ordinary(), layout.slots()), (1, &[9][..], 4));
/// assert!(Rotations::new(10, &[2]).is_err()); // 2..11 does not fit in 10 coordinates
/// # Ok::<(), femvi::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rotations {
    n: usize,
    offsets: Vec<usize>,
    ordinary: Vec<usize>,
}

impl Rotations {
    /// The layout of `n` coordinates with a rotation block of nine starting at each of
    /// `offsets`.
    ///
    /// # Errors
    /// No rotation, a block that does not fit in n, or blocks that overlap.
    pub fn new(n: usize, offsets: &[usize]) -> Result<Self> {
        if offsets.is_empty() {
            return Err(invalid("rotations", "no rotation block given"));
        }
        let mut taken = vec![false; n];
        for &o in offsets {
            let end = o.checked_add(9).filter(|&e| e <= n).ok_or_else(|| {
                invalid(
                    "rotations",
                    format!("the block at coordinate {o} needs nine coordinates, {n} in all"),
                )
            })?;
            for slot in &mut taken[o..end] {
                if *slot {
                    return Err(invalid(
                        "rotations",
                        format!("the block at coordinate {o} overlaps another"),
                    ));
                }
                *slot = true;
            }
        }
        let ordinary = (0..n).filter(|&c| !taken[c]).collect();
        Ok(Self {
            n,
            offsets: offsets.to_vec(),
            ordinary,
        })
    }

    /// The number of coordinates n.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// The number of rotations.
    pub fn count(&self) -> usize {
        self.offsets.len()
    }

    /// Where each rotation's nine entries start.
    pub fn offsets(&self) -> &[usize] {
        &self.offsets
    }

    /// The ordinary coordinates, in order.
    pub fn ordinary(&self) -> &[usize] {
        &self.ordinary
    }

    /// The unknowns per node: 3 per rotation and 1 per ordinary coordinate.
    pub fn slots(&self) -> usize {
        3 * self.offsets.len() + self.ordinary.len()
    }
}
