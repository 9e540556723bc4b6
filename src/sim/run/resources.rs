//! CPU time and memory of the running simulation (Linux /proc; zero elsewhere).

/// CPU seconds used by the calling thread (falls back to process CPU time).
pub fn thread_cpu_seconds() -> f64 {
    // schedstat: first field is nanoseconds spent on the CPU.
    for path in ["/proc/thread-self/schedstat", "/proc/self/schedstat"] {
        if let Ok(s) = std::fs::read_to_string(path)
            && let Some(ns) = s
                .split_whitespace()
                .next()
                .and_then(|v| v.parse::<f64>().ok())
        {
            return ns * 1e-9;
        }
    }
    0.0
}

/// Peak resident memory of the process (VmHWM), in bytes.
pub fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}
