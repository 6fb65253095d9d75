//! The few system calls std does not wrap: batched UDP, poll, socket buffer
//! sizes, and per-thread CPU time.

use std::io;
use std::mem::{size_of, zeroed};
use std::os::fd::{AsRawFd, RawFd};
use std::time::Duration;

/// Datagrams moved per `recvmmsg`/`sendmmsg` call on the measuring side.
pub const BATCH: usize = 64;
/// Receive slot: the 100-byte packet fits; anything longer is truncated and rejected.
pub const SLOT: usize = 128;

/// Asks for a receive buffer of `bytes`, past `rmem_max` if we may (root), else up to it.
pub fn set_rcvbuf(sock: &impl AsRawFd, bytes: usize) -> io::Result<usize> {
    let fd = sock.as_raw_fd();
    let val = bytes.min(i32::MAX as usize) as libc::c_int;
    // SAFETY: `val` is a live c_int and the length passed is its size.
    let forced = unsafe {
        libc::setsockopt(
            fd,
            libc::SOL_SOCKET,
            libc::SO_RCVBUFFORCE,
            (&val as *const libc::c_int).cast(),
            size_of::<libc::c_int>() as libc::socklen_t,
        )
    };
    if forced != 0 {
        // SAFETY: as above.
        let r = unsafe {
            libc::setsockopt(
                fd,
                libc::SOL_SOCKET,
                libc::SO_RCVBUF,
                (&val as *const libc::c_int).cast(),
                size_of::<libc::c_int>() as libc::socklen_t,
            )
        };
        if r != 0 {
            return Err(io::Error::last_os_error());
        }
    }
    let mut got: libc::c_int = 0;
    let mut len = size_of::<libc::c_int>() as libc::socklen_t;
    // SAFETY: `got` and `len` are live and sized as getsockopt expects.
    let r = unsafe {
        libc::getsockopt(
            fd,
            libc::SOL_SOCKET,
            libc::SO_RCVBUF,
            (&mut got as *mut libc::c_int).cast(),
            &mut len,
        )
    };
    if r != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(got as usize)
}

/// Buffers for receiving a batch of small datagrams on a connected socket.
pub struct RecvBatch {
    buf: Vec<u8>,
    lens: [usize; BATCH],
}

impl RecvBatch {
    pub fn new() -> RecvBatch {
        RecvBatch {
            buf: vec![0; SLOT * BATCH],
            lens: [0; BATCH],
        }
    }

    /// Datagram `i` of the last receive (a truncated one comes back too long to be a packet).
    pub fn get(&self, i: usize) -> &[u8] {
        &self.buf[i * SLOT..i * SLOT + self.lens[i]]
    }

    /// Receives up to [`BATCH`] waiting datagrams without blocking; returns how many.
    pub fn recv(&mut self, fd: RawFd) -> io::Result<usize> {
        // SAFETY: all-zero is a valid value for these plain C structs; every
        // pointer the kernel follows is set below.
        let mut iovs: [libc::iovec; BATCH] = unsafe { zeroed() };
        let mut hdrs: [libc::mmsghdr; BATCH] = unsafe { zeroed() };
        for (i, chunk) in self.buf.chunks_exact_mut(SLOT).enumerate() {
            iovs[i] = libc::iovec {
                iov_base: chunk.as_mut_ptr().cast(),
                iov_len: SLOT,
            };
            hdrs[i].msg_hdr.msg_iov = &mut iovs[i];
            hdrs[i].msg_hdr.msg_iovlen = 1;
        }
        // SAFETY: `hdrs` holds BATCH headers, each pointing at its own iovec,
        // which points at SLOT bytes of `self.buf`; all outlive the call.
        let r = unsafe {
            libc::recvmmsg(
                fd,
                hdrs.as_mut_ptr(),
                BATCH as libc::c_uint,
                libc::MSG_DONTWAIT,
                std::ptr::null_mut(),
            )
        };
        if r < 0 {
            let e = io::Error::last_os_error();
            return match e.kind() {
                io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted => Ok(0),
                _ => Err(e),
            };
        }
        let n = r as usize;
        for (len, hdr) in self.lens.iter_mut().zip(&hdrs).take(n) {
            let truncated = hdr.msg_hdr.msg_flags & libc::MSG_TRUNC != 0;
            *len = if truncated {
                SLOT
            } else {
                (hdr.msg_len as usize).min(SLOT)
            };
        }
        Ok(n)
    }
}

/// Sends each datagram in `msgs` on a connected socket, as few calls as the
/// kernel allows. Returns how many were accepted (the rest got `EAGAIN`).
pub fn send_batch(fd: RawFd, msgs: &[&[u8]]) -> io::Result<usize> {
    let mut sent = 0;
    for chunk in msgs.chunks(BATCH) {
        // SAFETY: as in `RecvBatch::recv`.
        let mut iovs: [libc::iovec; BATCH] = unsafe { zeroed() };
        let mut hdrs: [libc::mmsghdr; BATCH] = unsafe { zeroed() };
        for (i, m) in chunk.iter().enumerate() {
            iovs[i] = libc::iovec {
                iov_base: m.as_ptr() as *mut libc::c_void,
                iov_len: m.len(),
            };
            hdrs[i].msg_hdr.msg_iov = &mut iovs[i];
            hdrs[i].msg_hdr.msg_iovlen = 1;
        }
        let mut start = 0;
        while start < chunk.len() {
            // SAFETY: headers `start..chunk.len()` point at live iovecs that
            // point at the caller's buffers; the kernel only reads them.
            let r = unsafe {
                libc::sendmmsg(
                    fd,
                    hdrs.as_mut_ptr().add(start),
                    (chunk.len() - start) as libc::c_uint,
                    0,
                )
            };
            if r < 0 {
                let e = io::Error::last_os_error();
                match e.kind() {
                    io::ErrorKind::Interrupted => continue,
                    io::ErrorKind::WouldBlock => return Ok(sent),
                    _ => return Err(e),
                }
            }
            start += r as usize;
            sent += r as usize;
        }
    }
    Ok(sent)
}

/// An epoll set of sockets, each named by its index.
pub struct Epoll {
    fd: libc::c_int,
    events: Vec<libc::epoll_event>,
}

impl Epoll {
    pub fn new() -> io::Result<Epoll> {
        // SAFETY: epoll_create1 takes only flags.
        let fd = unsafe { libc::epoll_create1(libc::EPOLL_CLOEXEC) };
        if fd < 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(Epoll {
            fd,
            events: Vec::new(),
        })
    }

    /// Watches `fd` for reading (level-triggered), reported as `token`.
    pub fn add(&mut self, fd: RawFd, token: usize) -> io::Result<()> {
        let mut ev = libc::epoll_event {
            events: libc::EPOLLIN as u32,
            u64: token as u64,
        };
        // SAFETY: `ev` is a live epoll_event; both descriptors are open.
        if unsafe { libc::epoll_ctl(self.fd, libc::EPOLL_CTL_ADD, fd, &mut ev) } != 0 {
            return Err(io::Error::last_os_error());
        }
        self.events.push(libc::epoll_event { events: 0, u64: 0 });
        Ok(())
    }

    /// Waits up to `timeout` and returns the tokens of the readable sockets.
    pub fn wait(&mut self, timeout: Duration) -> io::Result<impl Iterator<Item = usize> + '_> {
        let ms = timeout.as_millis().min(i32::MAX as u128) as libc::c_int;
        // SAFETY: `events` has room for as many events as the length passed.
        let r = unsafe {
            libc::epoll_wait(
                self.fd,
                self.events.as_mut_ptr(),
                self.events.len().max(1) as libc::c_int,
                ms,
            )
        };
        let n = if r < 0 {
            let e = io::Error::last_os_error();
            if e.kind() != io::ErrorKind::Interrupted {
                return Err(e);
            }
            0
        } else {
            r as usize
        };
        Ok(self.events[..n].iter().map(|e| e.u64 as usize))
    }
}

impl Drop for Epoll {
    fn drop(&mut self) {
        // SAFETY: `fd` is ours and closed once.
        unsafe { libc::close(self.fd) };
    }
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

fn pin(tid: libc::pid_t, cpus: Option<&[usize]>) -> io::Result<()> {
    // SAFETY: an all-zero cpu_set_t is the empty set.
    let mut set: libc::cpu_set_t = unsafe { zeroed() };
    let all: Vec<usize> =
        (0..std::thread::available_parallelism().map_or(1, |n| n.get())).collect();
    for &c in cpus.unwrap_or(&all) {
        // SAFETY: CPU_SET writes one bit of `set`; `c` is a small CPU index.
        unsafe { libc::CPU_SET(c, &mut set) };
    }
    // SAFETY: `set` is a live cpu_set_t and its size is passed.
    let r = unsafe { libc::sched_setaffinity(tid, size_of::<libc::cpu_set_t>(), &set) };
    if r != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// The calling thread's kernel id, for reading its CPU time from another thread.
pub fn gettid() -> i32 {
    // SAFETY: gettid takes nothing and cannot fail.
    unsafe { libc::gettid() }
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
    // SAFETY: sysconf only reads a configuration value.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    let hz = if hz > 0 { hz as u64 } else { 100 };
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
    // SAFETY: sysconf only reads a configuration value.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    let hz = if hz > 0 { hz as u64 } else { 100 };
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
