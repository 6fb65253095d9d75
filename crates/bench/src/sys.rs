//! What the benchmarks read from the system: CPU times from `/proc`, the
//! kernel's UDP drop counter, outside load; and the system calls they make,
//! through colony-sys, which holds the `unsafe` they need.

use std::io;
use std::net::UdpSocket;
use std::time::Duration;

use colony_sys::buffers::{self, Buffer};
pub use colony_sys::wait::Epoll;

/// Datagrams moved per `recvmmsg`/`sendmmsg` call on the measuring side.
pub const BATCH: usize = 64;
/// Receive slot: every benchmark packet (400 bytes at most) fits; anything longer is truncated and rejected.
pub const SLOT: usize = 512;

/// Buffers for receiving a batch of small datagrams.
pub type RecvBatch = colony_sys::udp::RecvBatch<BATCH>;

/// Asks for a receive buffer of `bytes`, past `rmem_max` if we may (root),
/// else up to it. Returns the size in force, as the kernel reports it.
pub fn set_rcvbuf(sock: &UdpSocket, bytes: usize) -> io::Result<usize> {
    if buffers::set_size(sock, Buffer::Receive, bytes, true).is_err() {
        buffers::set_size(sock, Buffer::Receive, bytes, false)?;
    }
    buffers::size(sock, Buffer::Receive)
}

/// Sends each datagram in `msgs` on a connected socket, as few calls as the
/// kernel allows. Returns how many were accepted (the rest got `EAGAIN`).
pub fn send_batch(sock: &UdpSocket, msgs: &[&[u8]]) -> io::Result<usize> {
    colony_sys::udp::send_connected(sock, msgs)
}

/// Runs the calling thread on these CPUs only (`None`: on every CPU).
pub fn pin_self(cpus: Option<&[usize]>) -> io::Result<()> {
    pin(0, cpus)
}

/// Runs every thread of process `pid` on these CPUs only (`None`: on every CPU).
pub fn pin_process(pid: u32, cpus: Option<&[usize]>) -> io::Result<()> {
    let tasks = std::fs::read_dir(format!("/proc/{pid}/task"))?;
    for t in tasks {
        if let Some(tid) = t?.file_name().to_str().and_then(|s| s.parse().ok()) {
            pin(tid, cpus)?;
        }
    }
    Ok(())
}

fn pin(tid: colony_sys::thread::Tid, cpus: Option<&[usize]>) -> io::Result<()> {
    let all: Vec<usize> =
        (0..std::thread::available_parallelism().map_or(1, |n| n.get())).collect();
    colony_sys::thread::set_affinity(tid, cpus.unwrap_or(&all))
}

/// The calling thread's kernel id, for reading its CPU time from another thread.
pub fn gettid() -> i32 {
    colony_sys::thread::current_tid()
}

/// CPU time (user + system) a thread of this process has used so far.
pub fn thread_cpu(tid: i32) -> Option<Duration> {
    stat_cpu(&format!("/proc/self/task/{tid}/stat"))
}

/// CPU time (user + system) a process has used so far.
pub fn process_cpu(pid: u32) -> Option<Duration> {
    stat_cpu(&format!("/proc/{pid}/stat"))
}

fn stat_cpu(path: &str) -> Option<Duration> {
    let text = std::fs::read_to_string(path).ok()?;
    // The command name may hold blanks; fields are counted after its closing paren.
    let rest = &text[text.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of stat, 12 and 13 after the name.
    let utime: u64 = fields.get(11)?.parse().ok()?;
    let stime: u64 = fields.get(12)?.parse().ok()?;
    let hz = colony_sys::thread::clock_ticks_per_second();
    Some(Duration::from_nanos((utime + stime) * 1_000_000_000 / hz))
}

/// The kernel's count of UDP datagrams dropped at a full receive buffer
/// (`Udp: RcvbufErrors` in /proc/net/snmp), machine-wide.
pub fn udp_rcvbuf_errors() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/net/snmp").ok()?;
    let mut udp = text.lines().filter(|l| l.starts_with("Udp: "));
    let names = udp.next()?;
    let values = udp.next()?;
    let i = names.split_whitespace().position(|n| n == "RcvbufErrors")?;
    values.split_whitespace().nth(i)?.parse().ok()
}

/// CPU time all CPUs have spent busy so far (everything but idle and iowait),
/// from the first line of /proc/stat.
pub fn machine_busy() -> Option<Duration> {
    let text = std::fs::read_to_string("/proc/stat").ok()?;
    let line = text.lines().next()?.strip_prefix("cpu ")?;
    let ticks: Vec<u64> = line
        .split_whitespace()
        .map(|t| t.parse().unwrap_or(0))
        .collect();
    // user nice system idle iowait irq softirq steal (guest time is inside user)
    let busy: u64 = [0, 1, 2, 5, 6, 7]
        .iter()
        .filter_map(|&i| ticks.get(i))
        .sum();
    let hz = colony_sys::thread::clock_ticks_per_second();
    Some(Duration::from_nanos(busy * 1_000_000_000 / hz))
}

/// Measures how much CPU processes other than ours (and the brokers we
/// started) used over a stretch of time: a sign of outside disturbance.
pub struct Foreign {
    start: std::time::Instant,
    busy: Option<Duration>,
    ours: Option<Duration>,
}

impl Foreign {
    pub fn start(pids: &[u32]) -> Foreign {
        Foreign {
            start: std::time::Instant::now(),
            busy: machine_busy(),
            ours: ours(pids),
        }
    }

    /// Outside CPU use since `start`, in % of the whole machine.
    pub fn percent(&self, pids: &[u32]) -> Option<f64> {
        let wall = self.start.elapsed().as_secs_f64();
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
        let busy = machine_busy()?.checked_sub(self.busy?)?;
        let ours = ours(pids)?.checked_sub(self.ours?)?;
        Some((100.0 * busy.saturating_sub(ours).as_secs_f64() / (wall * cores)).min(100.0))
    }
}

fn ours(pids: &[u32]) -> Option<Duration> {
    let mut total = process_cpu(std::process::id())?;
    for &p in pids {
        total += process_cpu(p)?;
    }
    Some(total)
}

/// Waits, at most `limit`, until processes other than ours used less than
/// `below` % of the machine over half a second. Returns the last share seen.
pub fn wait_quiet(pids: &[u32], below: f64, limit: Duration) -> Option<f64> {
    let end = std::time::Instant::now() + limit;
    loop {
        let f = Foreign::start(pids);
        std::thread::sleep(Duration::from_millis(500));
        let share = f.percent(pids);
        if share.is_none_or(|s| s < below) || std::time::Instant::now() >= end {
            return share;
        }
    }
}
