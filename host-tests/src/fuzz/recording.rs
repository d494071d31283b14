//! The recording reader on arbitrary file contents: every outcome is a sample or a typed error
//! (and its message), never a panic.

use crate::recording::{HeaderMode, ReaderOptions, RecordingReader};
use std::io::Write;

/// The recording target: the first byte picks the column mapping and header mode, the rest is
/// the file. Every outcome must be a sample or a typed error whose message formats.
pub fn target(data: &[u8]) {
    let Some((&mode, body)) = data.split_first() else {
        return;
    };
    // tmpfs when available: the reader takes a path, and a disk file per execution is the bottleneck.
    let dir = if std::path::Path::new("/dev/shm").is_dir() {
        std::path::PathBuf::from("/dev/shm")
    } else {
        std::env::temp_dir()
    };
    // One file per thread: the corpus test runs the target on every core.
    let path = dir.join(format!(
        "sledid-fuzz-recording-{}-{:?}.csv",
        std::process::id(),
        std::thread::current().id()
    ));
    let Ok(mut f) = std::fs::File::create(&path) else {
        return;
    };
    if f.write_all(body).is_err() {
        return;
    }
    drop(f);
    let mapping = match mode % 3 {
        0 => "u=0,y=1",
        1 => "u=0,y=1,t=2",
        _ => "u=a,y=b,r=c",
    };
    let Ok(mapping) = mapping.parse() else { return };
    let mut opts = ReaderOptions::new(mapping);
    opts.header = match (mode / 3) % 3 {
        0 => HeaderMode::Auto,
        1 => HeaderMode::Present,
        _ => HeaderMode::Absent,
    };
    if mode & 0x80 != 0 {
        opts.ts_s = Some(1e-3);
    }
    // Every error is formatted too: its message quotes the file's text as a bounded excerpt.
    match RecordingReader::open(&path, &opts) {
        Ok(reader) => {
            for item in reader.take(100_000) {
                if let Err(error) = item {
                    let _ = error.to_string();
                    break;
                }
            }
        }
        Err(error) => drop(error.to_string()),
    }
}
