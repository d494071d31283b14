//! The host's integration tests, one module per subject, linked into one test binary: one link
//! instead of one per file, and libtest runs every test on every core instead of one binary after
//! another (`cargo test -p sledid-host --test integration MODULE::` runs one module).

mod calibration;
mod cli;
mod closed_loop_faults;
mod control;
mod control_family;
mod emps_vs_f64;
mod faults;
mod firmware_qemu;
mod fuzz_corpus;
mod health;
mod neuron_decimate;
mod nonlinear;
mod nonlinear_units;
mod paper_sled_control;
mod placement_poles;
mod properties;
mod recording;
mod replay;
mod rls_vs_f64;
mod safety;
mod scheduled_control;
mod seek;
mod seek_bound;
mod seek_family;
mod seek_learning;
mod sled_loop;
mod study;
mod study_nonlinear;
mod study_paper_twin;
mod study_recommend;
mod twin;
mod unit_sweep;
mod windup;
