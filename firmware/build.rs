//! The QEMU image's vector table: cortex-m-rt's `device` feature (`Cargo.toml`) drops its generic
//! table of every interrupt a core may have (240 on v7-M: 960 bytes of flash) for the image's own
//! one-entry `__INTERRUPTS` (`src/main.rs`); its `link.x` then includes a `device.x`, which this
//! script puts on the search path of this package's binaries only (not of the board image,
//! `boards/*`, which links its HAL's table and `device.x`). The image enables no device
//! interrupt: SysTick is a core exception, in cortex-m-rt's part of the table.
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let Some(out) = std::env::var_os("OUT_DIR").map(PathBuf::from) else {
        println!("cargo:warning=OUT_DIR not set: device.x not written");
        return;
    };
    let device_x = "/* sledid-fw: no device interrupt has a handler of its own (src/main.rs, \
                    `__INTERRUPTS`). */\n";
    if let Err(e) = std::fs::write(out.join("device.x"), device_x) {
        println!("cargo:warning=cannot write device.x: {e}");
        return;
    }
    println!("cargo:rustc-link-arg-bins=-L{}", out.display());
}
