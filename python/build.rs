//! No build step: the build dependencies only align features (see Cargo.toml).
fn main() {}
