//! The host's end of the PIL link: the firmware image under `qemu-system-arm -icount`, two FIFOs
//! in QEMU's working directory (`sledid_firmware::LINK_DOWN`, `LINK_UP`), a watchdog, and the defmt log.
//!
//! QEMU runs with `-icount shift=6,sleep=off`: virtual time advances 64 ns per instruction and
//! jumps over idle periods, so the firmware sees the same timing whatever the host's speed, and a
//! semihosting call (each frame) stops the emulator without costing virtual time.

use std::fs::{File, OpenOptions};
use std::io::{ErrorKind, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use sledid_firmware::{DownFrame, LINK_DOWN, LINK_UP, UP_FRAME_BYTES, UpFrame};

/// A firmware target: its Rust target, QEMU's CPU and machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Core {
    /// Cortex-M4F (`thumbv7em-none-eabihf`) on QEMU `mps2-an386`.
    M4f,
    /// Cortex-M0 (`thumbv6m-none-eabi`) on QEMU `microbit` (the image is built for an M0+).
    M0,
}

impl Core {
    /// Both cores.
    pub const ALL: [Core; 2] = [Core::M4f, Core::M0];

    /// The Rust target.
    pub fn target(self) -> &'static str {
        match self {
            Core::M4f => "thumbv7em-none-eabihf",
            Core::M0 => "thumbv6m-none-eabi",
        }
    }

    /// QEMU's `-cpu`.
    pub fn qemu_cpu(self) -> &'static str {
        match self {
            Core::M4f => "cortex-m4",
            Core::M0 => "cortex-m0",
        }
    }

    /// QEMU's `-machine`.
    pub fn qemu_machine(self) -> &'static str {
        match self {
            Core::M4f => "mps2-an386",
            Core::M0 => "microbit",
        }
    }

    /// `count_insns.py`'s `--arch`.
    pub fn count_arch(self) -> &'static str {
        match self {
            Core::M4f => "m4f",
            Core::M0 => "m0plus",
        }
    }

    /// A short name.
    pub fn name(self) -> &'static str {
        match self {
            Core::M4f => "m4f",
            Core::M0 => "m0",
        }
    }
}

/// QEMU's `-icount`: 2⁶ ns of virtual time per instruction, no real-time sleep when idle.
pub const ICOUNT: &str = "shift=6,sleep=off";

/// The program to run for `tool`: from `PATH`, else from cargo's `bin` directory (where
/// `cargo install` puts it, not always on `PATH`).
///
/// # Errors
/// When it is missing: a message with `install`, the command that installs it.
pub fn require_tool(tool: &str, install: &str) -> Result<PathBuf, String> {
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
            Ok(_) => return Ok(candidate),
            Err(e) if e.kind() == ErrorKind::NotFound => {}
            Err(e) => return Err(format!("cannot run `{}`: {e}", candidate.display())),
        }
    }
    Err(format!(
        "`{tool}` is not installed; the firmware runs need it. Install it with: {install} \
         (or run `cargo xtask setup`)"
    ))
}

/// `qemu-system-arm`.
///
/// # Errors
/// When it is not installed.
pub fn require_qemu() -> Result<PathBuf, String> {
    require_tool(
        "qemu-system-arm",
        "apt-get install -y --no-install-recommends qemu-system-arm",
    )
}

/// A running firmware image and its link.
pub struct QemuLink {
    child: Arc<Mutex<Child>>,
    down: Option<File>,
    up: File,
    dir: PathBuf,
    /// Milliseconds since `start` at the last completed exchange (the watchdog's clock).
    progress_ms: Arc<AtomicU64>,
    /// Set when the run is over: the watchdog stops.
    finished: Arc<AtomicBool>,
    /// Set when the watchdog killed QEMU.
    killed: Arc<AtomicBool>,
    /// When QEMU started.
    start: Instant,
    /// Exchanges completed.
    exchanges: u64,
}

/// What QEMU left when it exited.
pub struct QemuExit {
    /// QEMU's exit status (the firmware's semihosting exit code).
    pub status: ExitStatus,
    /// The defmt frames (semihosting stdout).
    pub defmt_frames: PathBuf,
    /// QEMU's own messages (stderr).
    pub stderr: String,
}

impl QemuLink {
    /// Starts `elf` for `core` under QEMU in `dir` (created, and its FIFOs), and opens the link.
    /// The watchdog kills QEMU when an exchange takes longer than `stall_timeout`.
    ///
    /// # Errors
    /// QEMU missing or failing to start, the FIFOs, or the firmware not opening the link in time.
    pub fn start(
        qemu: &Path,
        elf: &Path,
        core: Core,
        dir: &Path,
        stall_timeout: Duration,
    ) -> Result<Self, String> {
        let io = |what: &str, e: std::io::Error| format!("{what}: {e}");
        if dir.exists() {
            std::fs::remove_dir_all(dir).map_err(|e| io(&dir.display().to_string(), e))?;
        }
        std::fs::create_dir_all(dir).map_err(|e| io(&dir.display().to_string(), e))?;
        let down_path = dir.join(cstr_name(LINK_DOWN));
        let up_path = dir.join(cstr_name(LINK_UP));
        for fifo in [&down_path, &up_path] {
            let made = Command::new("mkfifo")
                .arg(fifo)
                .status()
                .map_err(|e| io("mkfifo", e))?;
            if !made.success() {
                return Err(format!("mkfifo {} failed: {made}", fifo.display()));
            }
        }
        let stdout = File::create(dir.join("defmt.bin")).map_err(|e| io("defmt.bin", e))?;
        let stderr = File::create(dir.join("stderr.txt")).map_err(|e| io("stderr.txt", e))?;
        let child = Command::new(qemu)
            .current_dir(dir)
            .args(["-cpu", core.qemu_cpu(), "-machine", core.qemu_machine()])
            .args(["-nographic", "-icount", ICOUNT])
            .args(["-semihosting-config", "enable=on,target=native", "-kernel"])
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(stderr)
            .spawn()
            .map_err(|e| io("start qemu-system-arm", e))?;
        let child = Arc::new(Mutex::new(child));

        // The opens block until the firmware opens its ends (in the same order); a thread does
        // them so that a firmware that never gets there is noticed.
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let opened = OpenOptions::new()
                .write(true)
                .open(&down_path)
                .and_then(|down| File::open(&up_path).map(|up| (down, up)));
            let _ = tx.send(opened);
        });
        let start = Instant::now();
        let (down, up) = loop {
            match rx.recv_timeout(Duration::from_millis(50)) {
                Ok(opened) => break opened.map_err(|e| io("open the link", e))?,
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err("the link's opener thread died".into());
                }
            }
            let exited = child.lock().map_err(|_| "QEMU lock")?.try_wait();
            if let Ok(Some(status)) = exited {
                let text = std::fs::read_to_string(dir.join("stderr.txt")).unwrap_or_default();
                return Err(format!(
                    "QEMU exited ({status}) before the firmware opened the link; stderr:\n{text}"
                ));
            }
            if start.elapsed() > stall_timeout {
                let _ = child.lock().map(|mut c| c.kill());
                return Err(format!(
                    "the firmware did not open the link within {stall_timeout:?}"
                ));
            }
        };

        let progress_ms = Arc::new(AtomicU64::new(start.elapsed().as_millis() as u64));
        let finished = Arc::new(AtomicBool::new(false));
        let killed = Arc::new(AtomicBool::new(false));
        {
            let (child, progress_ms, finished, killed) = (
                Arc::clone(&child),
                Arc::clone(&progress_ms),
                Arc::clone(&finished),
                Arc::clone(&killed),
            );
            let limit_ms = stall_timeout.as_millis() as u64;
            std::thread::spawn(move || {
                while !finished.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(200));
                    let now = start.elapsed().as_millis() as u64;
                    if now.saturating_sub(progress_ms.load(Ordering::Relaxed)) > limit_ms {
                        killed.store(true, Ordering::Relaxed);
                        let _ = child.lock().map(|mut c| c.kill());
                        return;
                    }
                }
            });
        }
        let link = Self {
            child,
            down: Some(down),
            up,
            dir: dir.to_path_buf(),
            progress_ms,
            finished,
            killed,
            start,
            exchanges: 0,
        };
        link.touch();
        Ok(link)
    }

    /// Tells the watchdog the link is alive.
    fn touch(&self) {
        let now = self.start.elapsed().as_millis() as u64;
        self.progress_ms.store(now, Ordering::Relaxed);
    }

    /// Sends `frame` and reads the answer.
    ///
    /// # Errors
    /// QEMU gone (or killed by the watchdog), or a broken pipe.
    pub fn exchange(&mut self, frame: &DownFrame) -> Result<UpFrame, String> {
        let down = self.down.as_mut().ok_or("the link is closed")?;
        let sent = down.write_all(&frame.to_bytes());
        let mut bytes = [0u8; UP_FRAME_BYTES];
        let got = sent.and_then(|()| self.up.read_exact(&mut bytes));
        if let Err(e) = got {
            let why = if self.killed.load(Ordering::Relaxed) {
                "the watchdog killed QEMU (no answer in time)".to_string()
            } else {
                format!("the link broke: {e}")
            };
            return Err(format!("exchange {}: {why}", self.exchanges));
        }
        self.exchanges += 1;
        self.touch();
        Ok(UpFrame::from_bytes(&bytes))
    }

    /// Sends the end frame and waits for QEMU to exit.
    ///
    /// # Errors
    /// QEMU did not exit in time, or its files cannot be read.
    pub fn finish(mut self, timeout: Duration) -> Result<QemuExit, String> {
        if let Some(mut down) = self.down.take() {
            // The firmware may already have stopped reading (after a link error): ignore.
            let _ = down.write_all(&DownFrame::END.to_bytes());
        }
        self.touch();
        let start = Instant::now();
        let status = loop {
            let polled = self.child.lock().map_err(|_| "QEMU lock")?.try_wait();
            match polled {
                Ok(Some(status)) => break status,
                Ok(None) if start.elapsed() > timeout => {
                    let _ = self.child.lock().map(|mut c| c.kill());
                    return Err(format!("QEMU did not exit within {timeout:?} of the end"));
                }
                Ok(None) => std::thread::sleep(Duration::from_millis(20)),
                Err(e) => return Err(format!("wait for QEMU: {e}")),
            }
        };
        self.finished.store(true, Ordering::Relaxed);
        let stderr = std::fs::read_to_string(self.dir.join("stderr.txt")).unwrap_or_default();
        Ok(QemuExit {
            status,
            defmt_frames: self.dir.join("defmt.bin"),
            stderr,
        })
    }
}

impl Drop for QemuLink {
    fn drop(&mut self) {
        self.finished.store(true, Ordering::Relaxed);
        if let Ok(mut c) = self.child.lock()
            && matches!(c.try_wait(), Ok(None))
        {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// A C string's text (the link's file names are ASCII).
fn cstr_name(name: &std::ffi::CStr) -> String {
    name.to_string_lossy().into_owned()
}

/// Decodes the defmt frames of `frames` with the image `elf`'s defmt table (the `defmt-decoder`
/// crate, which `defmt-print` wraps): one line per frame, its message. A malformed frame the
/// encoding can recover from (rzCOBS) is skipped and named in its own line.
///
/// # Errors
/// Either file unreadable, the image without a defmt table, or a malformed frame the encoding
/// cannot recover from.
pub fn decode_defmt(elf: &Path, frames: &Path) -> Result<String, String> {
    let image = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let table = defmt_decoder::Table::parse(&image)
        .map_err(|e| format!("{}: defmt table: {e}", elf.display()))?
        .ok_or_else(|| format!("{}: no defmt table", elf.display()))?;
    let data = std::fs::read(frames).map_err(|e| format!("{}: {e}", frames.display()))?;
    let mut decoder = table.new_stream_decoder();
    decoder.received(&data);
    let mut log = String::new();
    loop {
        match decoder.decode() {
            Ok(frame) => {
                log.push_str(&frame.display_message().to_string());
                log.push('\n');
            }
            Err(defmt_decoder::DecodeError::UnexpectedEof) => return Ok(log),
            Err(defmt_decoder::DecodeError::Malformed) if table.encoding().can_recover() => {
                log.push_str("(a malformed defmt frame skipped)\n");
            }
            Err(defmt_decoder::DecodeError::Malformed) => {
                return Err(format!("{}: a malformed defmt frame", frames.display()));
            }
        }
    }
}
