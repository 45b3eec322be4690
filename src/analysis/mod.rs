//! Studies of evaluated surfaces: continuity statistics across edges ([`stats`]), the
//! distance study against exact surfaces ([`distance`]), the paper's Table 1
//! ([`table1`]) and the fairness measures ([`fairness`]: bending energy, G2 defect).

pub mod distance;
pub mod fair;
pub mod fairness;
mod jet;
pub mod stats;
pub mod table1;
