//! The QEMU image's defmt logger: every frame to the host's stdout through semihosting, as
//! `defmt-semihosting` writes it (same bytes: one rzCOBS-encoded frame per `defmt::println!`,
//! decoded by `defmt-decoder` on the host), without a panic path.
//!
//! `defmt-semihosting` writes with `semihosting::io::Write::write_all`, whose `&buf[n..]` is a
//! slice-index panic, and panics on a logger taken reentrantly; a panic whose message formats a
//! number links `core::fmt` (≈ 1 KB of flash: `usize`'s `Display`, the digit table). Here a write
//! the host does not take is dropped (the host has gone: the run fails on its side anyway), and a
//! reentrant use (a panic while logging) writes nothing until the outer frame ends.

use core::cell::UnsafeCell;

use semihosting::io::{Stdout, Write};

/// The logger defmt calls.
#[defmt::global_logger]
struct Logger;

/// The logger's state; touched only between [`Logger`]'s `acquire` and `release`, inside the
/// critical section `acquire` takes.
struct Shared {
    /// Acquisitions not yet released: 1 while a frame is written, more when nested.
    depth: UnsafeCell<u32>,
    /// The interrupt state to restore on the outermost release.
    restore: UnsafeCell<critical_section::RestoreState>,
    /// The frame encoder.
    encoder: UnsafeCell<defmt::Encoder>,
    /// Semihosting's stdout, opened on first use.
    out: UnsafeCell<Option<Stdout>>,
}

// SAFETY: every access is inside the critical section taken by `acquire` (single core: nothing
// else runs until `release`), and only at depth 1 (see `Logger`'s methods).
#[allow(unsafe_code)]
unsafe impl Sync for Shared {}

/// The one instance.
static SHARED: Shared = Shared {
    depth: UnsafeCell::new(0),
    restore: UnsafeCell::new(critical_section::RestoreState::invalid()),
    encoder: UnsafeCell::new(defmt::Encoder::new()),
    out: UnsafeCell::new(None),
};

/// Writes `bytes` to `out`, as much as the host takes (nothing without a stdout). Out of line:
/// one copy for the three callers.
#[inline(never)]
fn write_out(out: &mut Option<Stdout>, mut bytes: &[u8]) {
    let Some(h) = out else { return };
    while !bytes.is_empty() {
        match h.write(bytes) {
            Ok(n) if n > 0 => bytes = bytes.get(n..).unwrap_or(&[]),
            _ => return,
        }
    }
}

// SAFETY (the trait's contract): `acquire` takes a critical section and `release` gives it back,
// so a frame is never interleaved with another; a nested `acquire` (a panic while logging) only
// counts, and its writes and release do nothing but count down.
#[allow(unsafe_code)]
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        // SAFETY: paired with the `release` below (the outermost) or released at once (nested).
        let restore = unsafe { critical_section::acquire() };
        // SAFETY: inside the critical section; no reference into SHARED outlives this block.
        unsafe {
            let depth = &mut *SHARED.depth.get();
            *depth = depth.saturating_add(1);
            if *depth > 1 {
                // Nested: the outer acquisition holds the section; this restore state is
                // "disabled", and releasing it leaves interrupts as they are.
                critical_section::release(restore);
                return;
            }
            SHARED.restore.get().write(restore);
            let out = &mut *SHARED.out.get();
            if out.is_none() {
                *out = semihosting::io::stdout().ok();
            }
            (*SHARED.encoder.get()).start_frame(|b| write_out(out, b));
        }
    }

    unsafe fn flush() {
        // Semihosting blocks until the host has the bytes: nothing is buffered here.
    }

    unsafe fn release() {
        // SAFETY: called after `acquire`, inside its critical section.
        unsafe {
            let depth = &mut *SHARED.depth.get();
            if *depth != 1 {
                *depth = depth.saturating_sub(1);
                return;
            }
            let out = &mut *SHARED.out.get();
            (*SHARED.encoder.get()).end_frame(|b| write_out(out, b));
            *depth = 0;
            critical_section::release(SHARED.restore.get().read());
        }
    }

    unsafe fn write(bytes: &[u8]) {
        // SAFETY: called between `acquire` and `release`, inside the critical section.
        unsafe {
            if *SHARED.depth.get() != 1 {
                return;
            }
            let out = &mut *SHARED.out.get();
            (*SHARED.encoder.get()).write(bytes, |b| write_out(out, b));
        }
    }
}
