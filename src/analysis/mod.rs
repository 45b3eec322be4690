//! Studies of evaluated surfaces: continuity statistics across edges ([`stats`]), the
//! distance study against exact surfaces ([`distance`]) and the paper's Table 1
//! ([`table1`]).

pub mod distance;
pub mod stats;
pub mod table1;
