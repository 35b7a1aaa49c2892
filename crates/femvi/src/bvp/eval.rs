//! The discrete action S = Σ_k L_d(w_k) of a boundary value problem and its derivatives in
//! the unknowns (paper (2.26)): the residual ∂S/∂x and the banded Jacobian ∂²S/∂x², assembled
//! element by element from the element's gradient and Hessian ([`Element::gradient_in_place`],
//! [`Element::hessian_in_place`]). On a moving mesh the element end times are variables too:
//! ∂L_d/∂t_k = E⁻ and ∂L_d/∂t_{k+1} = −E⁺ (the discrete energies, paper (3.3)) in the
//! residual, and the Jacobian from hyper-dual numbers over times and nodes
//! ([`Element::full_hessian`]).

use super::layout::Layout;
use super::{BoundaryValues, ElementTerm};
use crate::discrete::{Element, ElementWork};
use crate::lagrangian::Lagrangian;
use crate::solve::BandMatrix;

/// The problem, the numbering of its unknowns and the work space of the assembly.
pub(super) struct Assembly<'a, L: Lagrangian> {
    pub(super) lag: &'a L,
    pub(super) element: &'a Element,
    pub(super) bv: &'a BoundaryValues,
    pub(super) layout: Layout,
    pub(super) n: usize,
    pub(super) work: ElementWork,
    /// All global nodal values and all element end times, unpacked from the unknowns.
    pub(super) nodes: Vec<f64>,
    pub(super) times: Vec<f64>,
    pub(super) base: Vec<f64>,
    pub(super) incr: Vec<f64>,
    pub(super) grad: Vec<f64>,
    pub(super) hess: Vec<f64>,
    /// Terms added to each element's gradient and Hessian (non-conservative forces).
    pub(super) term: Option<&'a dyn ElementTerm>,
}

impl<'a, L: Lagrangian> Assembly<'a, L> {
    /// The assembly on the fixed mesh `times` from the global nodal values `nodes`.
    pub(super) fn new(
        lag: &'a L,
        element: &'a Element,
        bv: &'a BoundaryValues,
        nodes: Vec<f64>,
        times: Vec<f64>,
        term: Option<&'a dyn ElementTerm>,
    ) -> Self {
        let (n, s) = (lag.dim(), element.degree());
        let layout = Layout {
            n,
            s,
            elements: bv.elements,
            moving: false,
        };
        Assembly {
            lag,
            element,
            bv,
            layout,
            n,
            work: ElementWork::new(element, n),
            nodes,
            times,
            base: vec![0.0; n],
            incr: vec![0.0; (s + 1) * n],
            grad: vec![0.0; (s + 1) * n],
            hess: vec![0.0; ((s + 1) * n).pow(2)],
            term,
        }
    }
}

impl<L: Lagrangian> Assembly<'_, L> {
    /// Writes the unknowns `x` into `nodes` and (moving mesh) `times`. Returns the first
    /// element whose step is not positive, if any.
    pub(super) fn unpack(&mut self, x: &[f64]) -> Option<usize> {
        let (n, s, big_n) = (self.n, self.element.degree(), self.bv.elements);
        for g in 1..big_n * s {
            for c in 0..n {
                if let Some(i) = self.layout.node(g, c) {
                    self.nodes[g * n + c] = x[i];
                }
            }
        }
        for k in 1..big_n {
            if let Some(i) = self.layout.time(k) {
                self.times[k] = x[i];
            }
        }
        // A step that is not positive, or NaN.
        (0..big_n).find(|&k| (self.times[k + 1] - self.times[k]).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater))
    }

    /// The step of element k: exact for the uniform mesh (not a difference of times).
    pub(super) fn step(&self, k: usize) -> f64 {
        if self.layout.moving {
            self.times[k + 1] - self.times[k]
        } else {
            self.bv.step()
        }
    }

    /// Nodal values of element k into `base`, `incr`.
    pub(super) fn load(&mut self, k: usize) {
        let (n, s) = (self.n, self.element.degree());
        let g0 = k * s;
        self.base.copy_from_slice(&self.nodes[g0 * n..(g0 + 1) * n]);
        for j in 0..=s {
            for c in 0..n {
                self.incr[j * n + c] = self.nodes[(g0 + j) * n + c] - self.base[c];
            }
        }
    }

    /// Residual ∂S/∂x (and the Jacobian into `band` if given) at the unknowns `x`; the action,
    /// or Err(k) if element k has a step that is not positive (a folded mesh).
    pub(super) fn eval(
        &mut self,
        x: &[f64],
        r: &mut [f64],
        mut band: Option<&mut BandMatrix>,
    ) -> std::result::Result<f64, usize> {
        if let Some(k) = self.unpack(x) {
            return Err(k);
        }
        r.iter_mut().for_each(|v| *v = 0.0);
        if let Some(b) = band.as_deref_mut() {
            b.clear();
        }
        let mut action = 0.0;
        for k in 0..self.bv.elements {
            self.load(k);
            action += match band.as_deref_mut() {
                Some(b) if self.layout.moving => self.add_full_hessian(k, r, b),
                Some(b) => self.add_hessian(k, r, b),
                None => self.add_gradient(k, r),
            };
        }
        Ok(action)
    }

    /// Moving mesh, element k (loaded): adds its gradient in times and nodes to `r` and its
    /// Hessian to `band`; returns L_d.
    fn add_full_hessian(&mut self, k: usize, r: &mut [f64], band: &mut BandMatrix) -> f64 {
        let (tk, h) = (self.times[k], self.step(k));
        let (value, grad, hess) = self.element.full_hessian(self.lag, tk, h, &self.base, &self.incr);
        let m = 2 + (self.element.degree() + 1) * self.n;
        scatter(&self.layout, k, m, &grad, &hess, r, band);
        value
    }

    /// Fixed mesh, element k (loaded): adds its gradient in the nodes to `r` and its Hessian
    /// to `band`; returns L_d.
    fn add_hessian(&mut self, k: usize, r: &mut [f64], band: &mut BandMatrix) -> f64 {
        let (tk, h) = (self.times[k], self.step(k));
        let value = self.element.hessian_in_place(
            self.lag,
            tk,
            h,
            &self.base,
            &self.incr,
            &mut self.work,
            &mut self.grad,
            &mut self.hess,
        );
        if let Some(term) = self.term {
            term.add(tk, h, &self.base, &self.incr, &mut self.grad, Some(&mut self.hess));
        }
        let w = (self.element.degree() + 1) * self.n;
        scatter(&self.layout, k, w, &self.grad, &self.hess, r, band);
        value
    }

    /// Element k (loaded), residual only: adds its gradient in the nodes and (moving mesh)
    /// its derivatives in the end times, the discrete energies, to `r`; returns L_d.
    fn add_gradient(&mut self, k: usize, r: &mut [f64]) -> f64 {
        let (tk, h) = (self.times[k], self.step(k));
        let moving = self.layout.moving;
        let value = self.element.gradient_in_place(
            self.lag,
            tk,
            h,
            &self.base,
            &self.incr,
            moving,
            &mut self.work,
            &mut self.grad,
        );
        if let Some(term) = self.term {
            term.add(tk, h, &self.base, &self.incr, &mut self.grad, None);
        }
        let lead = if moving { 2 } else { 0 };
        let m = lead + (self.element.degree() + 1) * self.n;
        for a in lead..m {
            if let Some(row) = self.layout.local(k, a) {
                r[row] += self.grad[a - lead];
            }
        }
        if moving {
            // ∂L_d/∂t_k = E⁻, ∂L_d/∂t_{k+1} = −E⁺.
            let (e_minus, e_plus) = self.element.energies(h, &self.work);
            if let Some(row) = self.layout.local(k, 0) {
                r[row] += e_minus;
            }
            if let Some(row) = self.layout.local(k, 1) {
                r[row] -= e_plus;
            }
        }
        value
    }
}

/// Adds the gradient `grad` (m entries) and the row-major m×m Hessian `hess` of element k in
/// its local variables to the residual `r` and the Jacobian `band`, at the rows and columns
/// of the unknowns (local variables that are boundary values are left out).
fn scatter(layout: &Layout, k: usize, m: usize, grad: &[f64], hess: &[f64], r: &mut [f64], band: &mut BandMatrix) {
    for a in 0..m {
        let Some(row) = layout.local(k, a) else { continue };
        r[row] += grad[a];
        for c in 0..m {
            if let Some(col) = layout.local(k, c) {
                let added = band.add(row, col, hess[a * m + c]);
                debug_assert!(added.is_ok(), "the layout keeps an element's entries in the band");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvp::line_guess;
    use crate::fem::{NodeFamily, QuadratureKind};

    /// The assembled Jacobian of the moving-mesh system (hyper-dual numbers over times and
    /// nodes) is the derivative of its residual (gradient and discrete energies), by central
    /// differences, at a point off the solution with an uneven mesh.
    #[test]
    fn moving_mesh_jacobian_is_the_derivative_of_the_residual() {
        let lag = crate::models::pendulum(1.0, 1.0, 1.0).unwrap();
        let elements = [
            Element::midpoint(),
            Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(2)).unwrap(),
            Element::galerkin(3, NodeFamily::Lobatto, QuadratureKind::GaussLobatto(4)).unwrap(),
        ];
        for element in &elements {
            let bv = BoundaryValues {
                t0: 0.0,
                q0: vec![1.0],
                t1: 3.0,
                q1: vec![-0.5],
                elements: 4,
            };
            let s = element.degree();
            let layout = Layout {
                n: 1,
                s,
                elements: 4,
                moving: true,
            };
            let mut asm = Assembly {
                lag: &lag,
                element,
                bv: &bv,
                layout,
                n: 1,
                work: ElementWork::new(element, 1),
                nodes: line_guess(&bv, element),
                times: vec![0.0, 0.7, 1.5, 2.2, 3.0],
                base: vec![0.0; 1],
                incr: vec![0.0; s + 1],
                grad: vec![0.0; s + 1],
                hess: vec![0.0; (s + 1) * (s + 1)],
                term: None,
            };
            let len = layout.len();
            let mut x = vec![0.0; len];
            for g in 1..4 * s {
                x[layout.node(g, 0).unwrap()] = asm.nodes[g] + 0.1 * (g as f64).sin();
            }
            for k in 1..4 {
                x[layout.time(k).unwrap()] = asm.times[k];
            }
            let bw = layout.bandwidth();
            let mut band = BandMatrix::zeros(len, bw, bw).unwrap();
            let mut r = vec![0.0; len];
            asm.eval(&x, &mut r, Some(&mut band)).unwrap();
            let (mut rp, mut rm) = (vec![0.0; len], vec![0.0; len]);
            let d = 1e-6;
            for i in 0..len {
                let mut xp = x.clone();
                xp[i] += d;
                asm.eval(&xp, &mut rp, None).unwrap();
                let mut xm = x.clone();
                xm[i] -= d;
                asm.eval(&xm, &mut rm, None).unwrap();
                for row in 0..len {
                    let fd = (rp[row] - rm[row]) / (2.0 * d);
                    let jac = band.get(row, i);
                    assert!(
                        (fd - jac).abs() < 1e-6 * (1.0 + jac.abs()),
                        "degree {s}: J[{row}][{i}] = {jac} but the difference quotient is {fd}"
                    );
                }
            }
        }
    }
}
