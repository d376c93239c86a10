//! The release binary run from a benchmark as a user runs it, and what it cost, read from
//! `wait4`'s rusage: peak memory, and CPU time (user + system, every thread), which unlike
//! wall time does not grow with what else the machine is running.

use std::process::Command;
use std::time::Instant;

/// What one run of `lipmap` cost.
pub struct ChildUsage {
    pub code: i32,
    /// Peak resident memory, MB.
    pub peak_mb: f64,
    pub wall_s: f64,
    /// User + system CPU time of the process and its threads, seconds.
    pub cpu_s: f64,
}

/// Runs `lipmap args` (output discarded) and measures it.
// The child is reaped by `wait4`, which also gives its rusage; `Child::wait` cannot.
#[allow(clippy::zombie_processes)]
pub fn run_lipmap(args: &[&str]) -> ChildUsage {
    let start = Instant::now();
    let child = Command::new(env!("CARGO_BIN_EXE_lipmap"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("lipmap runs");
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: rusage is plain data that wait4 fills; the pid is our own child, reaped here
    // once (the `Child` is never waited on).
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let waited = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(waited, pid, "wait4 failed");
    let code = if libc::WIFEXITED(status) { libc::WEXITSTATUS(status) } else { -1 };
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    ChildUsage {
        code,
        // Linux reports ru_maxrss in kilobytes.
        peak_mb: usage.ru_maxrss as f64 / 1024.0,
        wall_s: start.elapsed().as_secs_f64(),
        cpu_s: seconds(usage.ru_utime) + seconds(usage.ru_stime),
    }
}
