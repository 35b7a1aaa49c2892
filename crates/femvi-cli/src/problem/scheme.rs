//! The `[scheme]` table: the element (midpoint rule, or a Galerkin element of some degree with
//! its nodes and quadrature, or one chosen by its order), checked and built as a library
//! [`Element`] with the label that summaries show.

use super::errors::{InputError, Source};
use femvi::{Element, NodeFamily, QuadratureKind};
use serde::Deserialize;

/// `[scheme] kind`.
#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum Kind {
    /// A Galerkin element of some degree (the default).
    #[default]
    Galerkin,
    /// The midpoint rule (2.19).
    Midpoint,
}

/// `[scheme] nodes`: where the element's interior nodes sit.
#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum Nodes {
    /// Equally spaced (the default).
    #[default]
    Equispaced,
    /// Gauss-Lobatto points.
    Lobatto,
}

/// `[scheme] quadrature`: the rule that approximates the action integral.
#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum Quadrature {
    /// One point.
    Midpoint,
    /// The two end points.
    Trapezoid,
    /// Simpson's three points.
    Simpson,
    /// Gauss-Legendre with `points` points (default: the degree; the default rule).
    #[default]
    GaussLegendre,
    /// Gauss-Lobatto with `points` points (default: the degree + 1).
    GaussLobatto,
}

/// `[scheme]` as written (absent: Galerkin degree 2, or the degree `[time] accuracy` picks,
/// with Gauss-Legendre quadrature).
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SchemeTable {
    /// Midpoint rule or Galerkin element.
    #[serde(default)]
    pub kind: Kind,
    /// Requested order 2s: picks degree s with s-point Gauss-Legendre (femvi's default choice).
    pub order: Option<usize>,
    /// Polynomial degree of the element.
    pub degree: Option<usize>,
    /// Interior node family.
    #[serde(default)]
    pub nodes: Nodes,
    /// Quadrature rule.
    #[serde(default)]
    pub quadrature: Quadrature,
    /// Number of quadrature points (Gauss rules only).
    pub points: Option<usize>,
}

impl SchemeTable {
    /// The element and its label. `accuracy` (`[time] accuracy`) picks the degree when
    /// neither `order` nor `degree` is given.
    pub fn element(&self, accuracy: Option<f64>, src: &Source) -> Result<(Element, String), InputError> {
        match self.kind {
            Kind::Midpoint => {
                if self.degree.is_some_and(|d| d != 1) || self.points.is_some() || self.order.is_some() {
                    return Err(src.error("[scheme] kind = \"midpoint\" takes no degree or points"));
                }
                Ok((Element::midpoint(), "midpoint (2.19)".to_string()))
            }
            Kind::Galerkin => self.galerkin(accuracy, src),
        }
    }

    /// A Galerkin element: degree from `order`, `degree` or `accuracy` (default 2).
    fn galerkin(&self, accuracy: Option<f64>, src: &Source) -> Result<(Element, String), InputError> {
        self.check_order(src)?;
        let degree = self
            .order
            .map(|o| o / 2)
            .or(self.degree)
            .or(accuracy
                .filter(|a| a.is_finite() && *a > 0.0)
                .map(femvi::step::auto::degree_for_accuracy))
            .unwrap_or(2);
        if degree == 0 || degree > 64 {
            return Err(src.error(format!("[scheme] degree = {degree} is out of range (1 to 64)")));
        }
        let rule = self.rule(degree, src)?;
        let family = match self.nodes {
            Nodes::Equispaced => NodeFamily::Equispaced,
            Nodes::Lobatto => NodeFamily::Lobatto,
        };
        let el = Element::galerkin(degree, family, rule).map_err(|e| src.error(format!("[scheme]: {e}")))?;
        el.check_nondegenerate()
            .map_err(|e| src.error(format!("[scheme]: {e}")))?;
        Ok((
            el,
            format!("galerkin degree {degree}, {:?} nodes, {rule:?}", self.nodes),
        ))
    }

    /// `order` excludes the other keys and is even, from 2 to 128.
    fn check_order(&self, src: &Source) -> Result<(), InputError> {
        let Some(order) = self.order else { return Ok(()) };
        if self.degree.is_some() || self.points.is_some() || self.quadrature != Quadrature::GaussLegendre {
            return Err(src.error("[scheme] order chooses the element itself: give order, or degree/quadrature/points"));
        }
        if order < 2 || order % 2 != 0 || order > 128 {
            return Err(src.error(format!("[scheme] order = {order} must be an even number from 2 to 128")));
        }
        Ok(())
    }

    /// The quadrature rule for an element of this degree.
    fn rule(&self, degree: usize, src: &Source) -> Result<QuadratureKind, InputError> {
        let rule = match self.quadrature {
            Quadrature::Midpoint => QuadratureKind::Midpoint,
            Quadrature::Trapezoid => QuadratureKind::Trapezoid,
            Quadrature::Simpson => QuadratureKind::Simpson,
            Quadrature::GaussLegendre => QuadratureKind::GaussLegendre(self.points.unwrap_or(degree)),
            Quadrature::GaussLobatto => QuadratureKind::GaussLobatto(self.points.unwrap_or(degree + 1)),
        };
        if matches!(
            self.quadrature,
            Quadrature::Midpoint | Quadrature::Trapezoid | Quadrature::Simpson
        ) && self.points.is_some()
        {
            return Err(src.error(format!(
                "[scheme] points does not apply to the {:?} rule",
                self.quadrature
            )));
        }
        if self.points.is_some_and(|p| p > 1000) {
            return Err(src.error("[scheme] points must be at most 1000"));
        }
        Ok(rule)
    }
}
