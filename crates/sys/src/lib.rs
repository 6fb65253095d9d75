//! The platform calls std does not wrap, written once for colony's hub,
//! client and benchmarks, and the only `unsafe` code in colony's networking.
//!
//! - [`udp`]: many datagrams per system call (`recvmmsg`/`sendmmsg` on
//!   Linux, one at a time elsewhere), UDP generic segmentation offload,
//!   and the kernel's count of datagrams dropped at a full receive buffer.
//! - [`wait`]: readiness waits, `poll` on one socket and an `epoll` set.
//! - [`buffers`]: a socket's kernel buffer sizes.
//! - [`thread`] and [`process`]: CPU affinity, thread ids, clock ticks and a
//!   child that dies with its parent, for the benchmarks.
//!
//! What this crate is not: a portable socket library (mio and socket2 are
//! that). It holds exactly the calls colony makes, each `unsafe` block with
//! the argument for its soundness beside it, so that every other crate can
//! say `#![forbid(unsafe_code)]`. It depends on libc only.
#![warn(missing_docs)]

pub mod buffers;
#[cfg(target_os = "linux")]
pub mod process;
#[cfg(target_os = "linux")]
pub mod thread;
pub mod udp;
pub mod wait;
