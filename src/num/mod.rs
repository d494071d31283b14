//! Number formats and the arithmetic on them.

pub mod boundary;
pub mod dyadic;
pub mod fixed;
pub(crate) mod float_bits;
pub mod gain;
pub mod wide;
