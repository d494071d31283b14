//! The firmware (`src/bin/firmware.rs`, binary `sledid-fw`) under QEMU, bit-exact with the host
//! replay of the same recording through the same loop step (`sledid::servo`, shadow mode:
//! scheduled controller, supervisor, velocity identifier) and the same
//! redesign rule (`fw_config::replay`).
//!
//! - `fixture_is_the_emps_excerpt`: the committed `fixtures/emps_excerpt.bin` is exactly the first
//!   `FIXTURE_SAMPLES` (640) rows of `shared/data/emps/DATA_EMPS.csv` converted at the boundary
//!   (`sledid::Scaling`). Set `SLEDID_WRITE_FIXTURE=1` to regenerate it (deliberately; review the
//!   diff).
//! - `loop_words_are_up_to_date`: the committed `src/bin/firmware/loop_words.rs` (the
//!   configuration the firmware decodes, `sledid::words`) is exactly what
//!   `fw_config::design().to_words()` gives now, and decodes to `design().build()`. Set
//!   `SLEDID_WRITE_CONFIG=1` to regenerate it after changing the design (review the diff).
//! - `altered_loop_words_are_refused`: short, long and corrupted words give
//!   `ConfigError::Words` (never a panic); random single-word changes either fail or decode.
//! - `host_replay_runs_the_whole_loop`: the host replay (`fw_config::replay`) is repeatable, the
//!   supervisor accepts the EMPS velocity prior and the identifier's θ stays near it.
//! - `cortex_m4f_matches_host_replay`, `cortex_m0_matches_host_replay`: build the firmware for
//!   `thumbv7em-none-eabihf` and `thumbv6m-none-eabi` (`cargo build --profile firmware`, the
//!   size-optimised release profile the image is meant to be flashed with, in its own target
//!   directory `target/fw` so the outer `cargo test` keeps its build lock), run each ELF under
//!   `qemu-system-arm` (mps2-an386, microbit) with a timeout, and assert: exit status 0 and the
//!   result line of the defmt log (semihosting stdout, decoded with `defmt-print -e ELF`) equal to
//!   the host replay's.
//!
//! Needs `qemu-system-arm` (`apt-get install -y --no-install-recommends qemu-system-arm`) and
//! `defmt-print` (`cargo install defmt-print --locked --version 1.2.0`); without them the tests
//! fail and say so.

#[path = "../../src/bin/firmware/config.rs"]
mod fw_config;

use std::io::ErrorKind;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use fw_config::{
    FIXTURE_SAMPLES, QUANTUM_M, RESULT_PREFIX, SAMPLE_PERIOD_NS, Summary, U_FULL_SCALE_V,
};
use sledid::error::ConfigError;
use sledid::servo::{SERVO_WORDS_MAX, SledServo};
use sledid::words::{WordWriter, Words};
use sledid::{Sample, Scaling};
use sledid_host::recording::{ReaderOptions, RecordingReader};

/// The recording the fixture is cut from.
const EMPS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../shared/data/emps/DATA_EMPS.csv"
);

/// The two firmware targets.
const M4F: &str = "thumbv7em-none-eabihf";
const M0: &str = "thumbv6m-none-eabi";

/// The workspace root (the `sledid` package).
fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("host-tests sits in the workspace")
        .to_path_buf()
}

/// The committed fixture.
fn fixture_path() -> PathBuf {
    workspace().join("fixtures/emps_excerpt.bin")
}

/// The separate target directory of the firmware builds.
fn firmware_target_dir() -> PathBuf {
    workspace().join("target/fw")
}

/// The first [`FIXTURE_SAMPLES`] rows of the EMPS estimation set, converted to fixed point.
fn emps_excerpt() -> Vec<Sample> {
    let options = ReaderOptions::new(
        "u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s"
            .parse()
            .expect("valid mapping"),
    );
    let scaling = Scaling::new(QUANTUM_M, U_FULL_SCALE_V).expect("valid scaling");
    RecordingReader::open(EMPS, &options)
        .expect("EMPS recording opens")
        .take(FIXTURE_SAMPLES)
        .map(|row| {
            let row = row.expect("EMPS row");
            let r = row.r.expect("EMPS has a reference column");
            scaling.sample(row.y, row.u, r).expect("EMPS row in range")
        })
        .collect()
}

/// The fixture layout (`fw_config::recording::encode`).
fn encode(samples: &[Sample]) -> Vec<u8> {
    let mut bytes = Vec::new();
    fw_config::recording::encode(samples, |b| bytes.push(b))
        .expect("every row fits the fixture layout");
    bytes
}

/// The committed fixture's bytes.
fn fixture_bytes() -> Vec<u8> {
    std::fs::read(fixture_path()).expect("fixtures/emps_excerpt.bin is committed")
}

/// The host replay of the fixture: what the firmware must print.
fn host_replay() -> Summary {
    fw_config::replay(&fixture_bytes()).expect("the firmware design builds")
}

#[test]
fn fixture_is_the_emps_excerpt() {
    let samples = emps_excerpt();
    assert_eq!(samples.len(), FIXTURE_SAMPLES, "rows in the recording");
    if std::env::var_os("SLEDID_WRITE_FIXTURE").is_some() {
        std::fs::write(fixture_path(), encode(&samples)).expect("write the fixture");
        println!("wrote {}", fixture_path().display());
    }
    let bytes = fixture_bytes();
    assert_eq!(bytes, encode(&samples), "fixture bytes");
    println!(
        "fixture: {} records in {} bytes ({:.2} per record)",
        FIXTURE_SAMPLES,
        bytes.len(),
        bytes.len() as f64 / FIXTURE_SAMPLES as f64
    );
    let mut cursor = fw_config::Cursor::new();
    for (i, expected) in samples.iter().enumerate() {
        assert_eq!(cursor.index(), i);
        assert_eq!(cursor.next(&bytes).as_ref(), Some(expected), "record {i}");
    }
    assert_eq!(cursor.next(&bytes), None, "past the end");
    assert_eq!(cursor.index(), FIXTURE_SAMPLES);
    assert_eq!(
        fw_config::recording::record(&bytes, 17).as_ref(),
        samples.get(17)
    );
    assert_eq!(
        fw_config::recording::record(&bytes, FIXTURE_SAMPLES),
        None,
        "past the end"
    );
    // The positions are on the encoder grid (whole quanta); the first row is 149 quanta.
    assert_eq!(samples.first().map(|s| s.y.raw()), Some(149 << 16));
    assert!(samples.iter().all(|s| s.y.raw() % (1 << 16) == 0));
}

/// The generated file of the firmware's configuration words.
fn loop_words_path() -> PathBuf {
    workspace().join("src/bin/firmware/loop_words.rs")
}

/// The configuration words of the firmware's design, now.
fn design_words() -> Vec<u32> {
    let mut buf = [0u32; SERVO_WORDS_MAX];
    let n = fw_config::design()
        .to_words(&mut buf)
        .expect("the firmware design builds into words");
    buf[..n].to_vec()
}

/// `loop_words.rs` for `words`.
fn render_loop_words(words: &[u32]) -> String {
    let mut s = String::from(
        "// @generated by `SLEDID_WRITE_CONFIG=1 cargo test -p sledid-host --test firmware_qemu \
         loop_words_are_up_to_date`\n\
         // from `fw_config::design()` with `ServoDesign::to_words`; do not edit.\n\n\
         /// The loop configuration of [`design`] as configuration words (`sledid::words`): built\n\
         /// and quantised on the host, decoded and checked on target by [`config`].\n",
    );
    s += &format!("pub const LOOP_WORDS: [u32; {}] = [\n", words.len());
    for line in words.chunks(6) {
        let items: Vec<String> = line.iter().map(|w| format!("0x{w:08x},")).collect();
        s += &format!("    {}\n", items.join(" "));
    }
    s += "];\n";
    s
}

#[test]
fn loop_words_are_up_to_date() {
    let words = design_words();
    let text = render_loop_words(&words);
    if std::env::var_os("SLEDID_WRITE_CONFIG").is_some() {
        std::fs::write(loop_words_path(), &text).expect("write loop_words.rs");
        println!(
            "wrote {} ({} words)",
            loop_words_path().display(),
            words.len()
        );
    }
    let committed = std::fs::read_to_string(loop_words_path()).expect("loop_words.rs is committed");
    assert_eq!(
        committed, text,
        "src/bin/firmware/loop_words.rs is stale: regenerate with SLEDID_WRITE_CONFIG=1"
    );
    assert_eq!(fw_config::LOOP_WORDS.as_slice(), words.as_slice());
    let built = fw_config::design().build().expect("the design builds");
    assert_eq!(fw_config::config(), Ok(built));
    assert_eq!(SledServo::from_words(&words), Ok(built));
    println!("{} configuration words", words.len());
}

/// `words` with its CRC-32 recomputed: a deliberate edit that the checksum does not catch, so
/// that the configuration's own checks are what refuse it.
fn resealed(mut words: Vec<u32>) -> Vec<u32> {
    let n = words.len();
    words[n - 1] = sledid::words::crc32::crc32_words(&words[..n - 1]);
    words
}

/// The frame: every truncation, an extra word, another version and every single-bit flip of the
/// committed words are refused (the CRC-32 catches all single-bit errors); decoding into a slot
/// leaves `None` on an error. Trips on a decoder that skips the version, length or CRC check.
#[test]
fn altered_loop_words_are_refused() {
    let words = design_words();
    assert_eq!(words.as_slice(), fw_config::LOOP_WORDS.as_slice());
    for n in 0..words.len() {
        let refused = SledServo::from_words(&words[..n]);
        assert!(
            matches!(
                refused,
                Err(ConfigError::Words { at: 1 } | ConfigError::WordsVersion(_))
            ),
            "{n} words: {refused:?}"
        );
    }
    let mut long = words.clone();
    long.push(0);
    assert_eq!(
        SledServo::from_words(&long),
        Err(ConfigError::Words { at: 1 })
    );
    let mut other = words.clone();
    other[0] ^= 1;
    assert_eq!(
        SledServo::from_words(&resealed(other)),
        Err(ConfigError::WordsVersion(sledid::words::WORDS_VERSION ^ 1))
    );
    let mut flips = 0;
    for at in 0..words.len() {
        for bit in 0..32 {
            let mut bad = words.clone();
            bad[at] ^= 1 << bit;
            let refused = SledServo::from_words(&bad);
            assert!(refused.is_err(), "bit {bit} of word {at} accepted");
            flips += 1;
        }
    }
    println!("{flips} single-bit flips, every one refused");
    let mut slot = None;
    assert_eq!(SledServo::from_words_into(&words, &mut slot), Ok(()));
    assert_eq!(slot, fw_config::design().build().ok());
    assert!(SledServo::from_words_into(&words[..words.len() - 1], &mut slot).is_err());
    assert_eq!(slot, None);
}

/// Past the CRC, the configuration's own checks: values out of their field's range, in the
/// controller's baseline PID (the controller's words come last, before the CRC; kp, ki·Ts, kd: 6
/// words, I_max and u_max: 4) — derivative_on (+10) has two variants (an encoding error at that
/// word), the derivative length (+11) is 1…4, β (+12) and 1 − α (+13) are at most 1 in U1F31 —
/// are refused with the error `PidDesign::build` names; random re-sealed single-word changes never
/// panic, and a configuration they leave valid still steps. Trips on a `validate` that misses a
/// check `build` makes.
#[test]
fn resealed_invalid_values_are_refused_by_the_build_checks() {
    let words = design_words();
    let controller = fw_config::design().controller.build().expect("controller");
    let mut buf = [0u32; SERVO_WORDS_MAX];
    let mut w = WordWriter::new(&mut buf);
    controller.put(&mut w).expect("controller words");
    let n = w.len();
    let end = words.len() - 1; // the CRC
    assert_eq!(&words[end - n..end], &buf[..n]);
    let pid = end - n;
    for (at, value, expected) in [
        (10, 2, ConfigError::Words { at: pid + 10 }),
        (11, 0, ConfigError::DerivativeSamples(0)),
        (11, 5, ConfigError::DerivativeSamples(5)),
    ] {
        let mut bad = words.clone();
        bad[pid + at] = value;
        assert_eq!(
            SledServo::from_words(&resealed(bad)),
            Err(expected),
            "word {} = {value}",
            pid + at
        );
    }
    for (at, value) in [(12, u32::MAX), (13, (1 << 31) + 1)] {
        let mut bad = words.clone();
        bad[pid + at] = value;
        let refused = SledServo::from_words(&resealed(bad));
        assert!(
            matches!(
                refused,
                Err(ConfigError::DerivativeLowPass(_) | ConfigError::ReferenceLowPass(_))
            ),
            "word {} = {value}: {refused:?}",
            pid + at
        );
    }
    let mut x = 0x2545_f491_4f6c_dd1d_u64;
    let (mut refused, mut stepped) = (0, 0);
    for trial in 0..20_000 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let mut bad = words.clone();
        let at = 2 + (x as usize) % (words.len() - 3); // the payload
        bad[at] = match trial % 3 {
            0 => (x >> 32) as u32,
            1 => bad[at] ^ (1 << ((x >> 40) % 32)),
            _ => bad[at].wrapping_add(1),
        };
        match SledServo::from_words(&resealed(bad)) {
            Err(_) => refused += 1,
            Ok(config) if trial % 50 == 0 => {
                let mut state = config.new_state();
                let fixture = fixture_bytes();
                let mut cursor = fw_config::Cursor::new();
                for _ in 0..64 {
                    let s = cursor.next(&fixture).expect("record");
                    config.step_shadow(&mut state, s.r, s.y, s.u);
                }
                stepped += 1;
            }
            Ok(_) => {}
        }
    }
    println!(
        "random re-sealed single-word changes: {refused} of 20000 refused, {stepped} accepted ones stepped"
    );
}

/// The recording's codec on values at the edges of its layout, on refused samples, and on cut
/// or corrupted bytes (never a panic).
#[test]
fn recording_codec_round_trips_and_refuses() {
    use sledid::{PositionI48F16, SignalI16F16};
    let sample = |y: i64, r: i64, u: i32| Sample {
        y: PositionI48F16::from_raw(y << 16),
        r: PositionI48F16::from_raw(r),
        u: SignalI16F16::from_raw(u),
    };
    let max_r = (1i64 << 47) - 1;
    let edges = [
        sample(0, 0, 0),
        sample(i64::from(i32::MAX), max_r, i32::from(i16::MAX)),
        sample(i64::from(i32::MIN), -max_r - 1, i32::from(i16::MIN)),
        sample(i64::from(i32::MAX), -max_r - 1, i32::from(i16::MAX)),
        sample(-1, 1, -1),
        sample(i64::from(i32::MIN), max_r, i32::from(i16::MIN)),
    ];
    let bytes = encode(&edges);
    let mut cursor = fw_config::Cursor::new();
    for (i, s) in edges.iter().enumerate() {
        assert_eq!(cursor.next(&bytes).as_ref(), Some(s), "edge {i}");
    }
    assert_eq!(cursor.next(&bytes), None);
    // Samples outside the layout are refused.
    for bad in [
        Sample {
            y: PositionI48F16::from_raw(1),
            ..edges[0]
        },
        sample(i64::from(i32::MAX) + 1, 0, 0),
        sample(0, 1 << 47, 0),
        sample(0, 0, 1 << 15),
    ] {
        assert_eq!(
            fw_config::recording::encode(&[bad], |_| {}),
            None,
            "{bad:?}"
        );
    }
    // Cut bytes: the records before the cut, then None, and the cursor stays put.
    for cut in 0..bytes.len() {
        let mut cursor = fw_config::Cursor::new();
        let mut n = 0;
        while cursor.next(&bytes[..cut]).is_some() {
            n += 1;
        }
        assert!(n < edges.len(), "cut at {cut}");
        let before = cursor;
        assert_eq!(cursor.next(&bytes[..cut]), None);
        assert_eq!(cursor, before);
    }
    // Corrupted bytes of the real fixture: never a panic, never past the end.
    let fixture = fixture_bytes();
    let mut x = 0x9e37_79b9_7f4a_7c15_u64;
    for _ in 0..200 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let mut bad = fixture.clone();
        let at = (x as usize) % bad.len();
        bad[at] ^= (x >> 32) as u8 | 1;
        let mut cursor = fw_config::Cursor::new();
        while cursor.next(&bad).is_some() {}
        assert!(cursor.index() <= bad.len() / 3);
    }
}

#[test]
fn host_replay_runs_the_whole_loop() {
    let s = host_replay();
    assert_eq!(s.samples as usize, FIXTURE_SAMPLES);
    // The supervisor accepts the EMPS velocity prior (else the baseline would drive throughout).
    assert!(!s.fallback, "{s}");
    // The velocity identifier learns from the recorded drive; θ = [a₁, b₁] stays near the prior
    // (a = 0.996, b = 69.4 from the whole recording).
    let theta = s.theta_raw.map(|t| f64::from(t) / f64::from(1 << 20));
    assert!(
        (theta[0] + 0.996).abs() < 0.01 && (theta[1] - 69.4).abs() < 10.0,
        "{s}"
    );
    // The same rule twice gives the same line.
    assert_eq!(host_replay(), s);
}

#[test]
fn checksum_is_fnv1a_64() {
    // Published FNV-1a 64 test vectors (the empty string is the offset basis).
    for (input, expected) in [
        ("", 0xcbf2_9ce4_8422_2325_u64),
        ("a", 0xaf63_dc4c_8601_ec8c),
        ("foobar", 0x8594_4171_f739_67e8),
    ] {
        let mut h = fw_config::Fnv1a64::new();
        h.write(input.as_bytes());
        assert_eq!(h.value(), expected, "FNV-1a 64 of {input:?}");
    }
}

/// The program to run for `tool`: from `PATH`, else from cargo's `bin` directory (where
/// `cargo install` puts it, not always on `PATH`). Fails with the install command when missing.
fn require_tool(tool: &str, install: &str) -> PathBuf {
    let cargo_bin = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".cargo")))
        .map(|home| home.join("bin").join(tool));
    for candidate in std::iter::once(PathBuf::from(tool)).chain(cargo_bin) {
        match Command::new(&candidate)
            .arg("--version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
        {
            Ok(_) => return candidate,
            Err(e) if e.kind() == ErrorKind::NotFound => {}
            Err(e) => panic!("cannot run `{}`: {e}", candidate.display()),
        }
    }
    panic!("`{tool}` is not installed; the firmware tests need it. Install it with: {install}")
}

/// Requires QEMU; the program to run.
fn require_qemu() -> PathBuf {
    require_tool(
        "qemu-system-arm",
        "apt-get install -y --no-install-recommends qemu-system-arm",
    )
}

/// Builds the firmware for both targets, once per test process; the ELF of `target`.
fn firmware_elf(target: &str) -> PathBuf {
    static BUILD: OnceLock<Result<(), String>> = OnceLock::new();
    let built = BUILD.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .current_dir(workspace())
            .args([
                "build",
                "--profile",
                "firmware",
                "-p",
                "sledid",
                "--bin",
                "sledid-fw",
            ])
            .args(["--target", M4F, "--target", M0])
            // Its own target directory: the outer `cargo test` holds the lock of its own.
            .env("CARGO_TARGET_DIR", firmware_target_dir())
            // These would replace the config's per-target rustflags (and drop `-Tlink.x`).
            .env_remove("RUSTFLAGS")
            .env_remove("CARGO_ENCODED_RUSTFLAGS")
            .status()
            .map_err(|e| format!("cannot run cargo: {e}"))?;
        if status.success() {
            Ok(())
        } else {
            Err(format!("firmware build failed: {status}"))
        }
    });
    if let Err(e) = built {
        panic!("{e}");
    }
    firmware_target_dir().join(format!("{target}/firmware/sledid-fw"))
}

/// What one QEMU run produced.
struct QemuRun {
    /// QEMU's exit status (the firmware's semihosting exit code).
    status: ExitStatus,
    /// Semihosting stdout: defmt frames.
    defmt_frames: PathBuf,
    /// Semihosting stderr (QEMU's own messages; the firmware writes nothing there).
    text: String,
}

/// Runs `elf` on `machine` until it exits through semihosting, or fails after a timeout.
fn run_qemu(qemu: &Path, elf: &Path, cpu: &str, machine: &str) -> QemuRun {
    let stem = format!("qemu-{machine}");
    let out_path = firmware_target_dir().join(format!("{stem}.defmt"));
    let err_path = firmware_target_dir().join(format!("{stem}.stderr"));
    let stdout = std::fs::File::create(&out_path).expect("create the QEMU stdout file");
    let stderr = std::fs::File::create(&err_path).expect("create the QEMU stderr file");
    let mut child = Command::new(qemu)
        .args(["-cpu", cpu, "-machine", machine, "-nographic"])
        .args(["-semihosting-config", "enable=on,target=native", "-kernel"])
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(stderr)
        .spawn()
        .expect("start qemu-system-arm");
    // The replay takes FIXTURE_SAMPLES sample periods of emulated time (0.9 s); allow for a slow,
    // loaded machine.
    let nominal = Duration::from_nanos(FIXTURE_SAMPLES as u64 * u64::from(SAMPLE_PERIOD_NS));
    let timeout = nominal * 20 + Duration::from_secs(60);
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for qemu") {
            break status;
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            let text = std::fs::read_to_string(&err_path).unwrap_or_default();
            panic!("{machine}: QEMU did not exit within {timeout:?}; stderr:\n{text}");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    println!("{machine}: QEMU ran {:.2?}", start.elapsed());
    let text = std::fs::read_to_string(&err_path).expect("read the QEMU stderr file");
    QemuRun {
        status,
        defmt_frames: out_path,
        text,
    }
}

/// Decodes the defmt frames with `defmt-print -e elf`.
fn decode_defmt(elf: &Path, frames: &Path) -> String {
    let defmt_print = require_tool(
        "defmt-print",
        "cargo install defmt-print --locked --version 1.2.0",
    );
    let input = std::fs::File::open(frames).expect("open the defmt frames");
    let out = Command::new(defmt_print)
        .arg("-e")
        .arg(elf)
        .stdin(input)
        .output()
        .expect("run defmt-print");
    assert!(
        out.status.success(),
        "defmt-print failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The firmware for `target` under QEMU equals the host replay.
fn matches_host_replay(target: &str, cpu: &str, machine: &str) {
    let qemu = require_qemu();
    let expected = host_replay();
    let elf = firmware_elf(target);
    let run = run_qemu(&qemu, &elf, cpu, machine);
    println!("{machine} ({target}) semihosting text:\n{}", run.text);
    assert!(
        run.status.success(),
        "{machine}: the firmware exited with {} (semihosting EXIT_FAILURE, or a crash); output:\n{}",
        run.status,
        run.text
    );

    assert_eq!(expected.samples as usize, FIXTURE_SAMPLES);
    let log = decode_defmt(&elf, &run.defmt_frames);
    println!("{machine} ({target}) defmt log:\n{log}");
    // `Summary`'s Display is the firmware's defmt line (slices as `[a, b]`).
    let expected_line = format!("{RESULT_PREFIX} {expected}");
    let line = log
        .lines()
        .find(|l| l.starts_with(RESULT_PREFIX))
        .unwrap_or_else(|| panic!("{machine}: no result line in the defmt log:\n{log}"));
    assert_eq!(
        line, expected_line,
        "{machine}: firmware (left) differs from the host replay (right)"
    );
    assert!(
        log.contains("telemetry Telemetry { index: 0,"),
        "{machine}: no telemetry record in the defmt log"
    );
    // The firmware itself fails unless received + dropped = samples; drops (a full queue while
    // the main loop logs) are possible on a loaded machine and are only reported.
    assert!(
        log.contains("telemetry: ") && log.contains(" redesigns; stack high-water "),
        "{machine}: no telemetry summary in the defmt log"
    );
}

#[test]
fn cortex_m4f_matches_host_replay() {
    matches_host_replay(M4F, "cortex-m4", "mps2-an386");
}

#[test]
fn cortex_m0_matches_host_replay() {
    matches_host_replay(M0, "cortex-m0", "microbit");
}
