//! Number formats and the arithmetic on them.

pub mod boundary;
pub mod dyadic;
pub mod fixed;
pub mod wide;
