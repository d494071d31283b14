//! The `sledid` command line as a shell user meets it.

use std::process::{Command, Stdio};

/// `sledid … | head` closes the pipe before the command has written everything: the command ends
/// quietly with success, not with a "Broken pipe" panic and status 101. The read end is closed
/// before the command writes its first line, so every write fails. Trips on a CLI without
/// `exit_quietly_on_a_closed_pipe` (measured: status 101 and a panic message on stderr).
#[test]
fn a_closed_pipe_ends_the_command_quietly() {
    let dir = std::env::temp_dir().join(format!("sledid-cli-pipe-{}", std::process::id()));
    let mut child = Command::new(env!("CARGO_BIN_EXE_sledid"))
        .args(["seek", "--seeks", "3", "--distances", "30:300", "--out"])
        .arg(&dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("sledid starts");
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("sledid ends");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
