//! Constrained two-point boundary value problems (placeholder, filled below).
