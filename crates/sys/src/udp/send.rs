//! Sending many datagrams to many destinations in as few system calls as
//! Linux allows: a [`SendPlan`] says which datagram goes where, a [`Sender`]
//! hands the whole plan to the kernel in one `sendmmsg` (per `UIO_MAXIOV`
//! messages), with each run of equal-length datagrams for one destination
//! (and a shorter one after it) as one UDP GSO message (`UDP_SEGMENT`)
//! where the kernel takes it, and, for a destination that asked for it,
//! several datagrams joined into one behind a head that says where to cut
//! them ([`Framing`]).

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::ops::Range;

use super::{RecvBatch, MAX_DATAGRAM, MAX_VLEN};

/// What became of the deliveries of one [`Sender::send`]: each of the plan's
/// datagrams to each of its destinations, whether it went alone, as a GSO
/// segment or joined with others.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct SendReport {
    /// Deliveries the kernel took.
    pub sent: usize,
    /// Deliveries dropped because the socket's send buffer (or the device
    /// queue) was full: [`Loss::Full`].
    pub full: usize,
    /// Deliveries dropped for any other reason: [`Loss::Failed`].
    pub failed: usize,
}

/// Why the kernel refused a datagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Loss {
    /// No room just now (`EAGAIN`, `EWOULDBLOCK`, `ENOBUFS`): the sender is
    /// faster than the way out, and the next datagram may well go.
    Full,
    /// Anything else: an unreachable network, a refused or invalid address.
    Failed,
}

impl Loss {
    /// Sorts a send error into its kind of loss.
    pub fn of(err: &io::Error) -> Loss {
        if err.kind() == io::ErrorKind::WouldBlock || err.raw_os_error() == Some(libc::ENOBUFS) {
            Loss::Full
        } else {
            Loss::Failed
        }
    }
}

/// How a [`Sender`] joins several datagrams for one destination into one:
/// a head from which the receiver learns where to cut, then each datagram
/// byte for byte. The format is the caller's (colony's is
/// `colony_wire::batch`); the sender needs only the head's size, to fill a
/// datagram without passing the destination's limit, and its bytes.
#[derive(Debug, Clone, Copy)]
pub struct Framing {
    /// Bytes of a head that names no datagram.
    pub base: usize,
    /// The bytes one datagram of this length adds to the head.
    pub per_part: fn(usize) -> usize,
    /// Appends the head for datagrams of these lengths (each at least 1
    /// byte); it must be `base` plus each length's `per_part` bytes long, or
    /// a joined datagram may pass its destination's limit.
    pub write_head: fn(&[usize], &mut Vec<u8>),
}

/// The most datagrams joined into one: with the head, one message's most
/// iovecs.
const MAX_JOINED: usize = MAX_VLEN - 1;

/// How many of the leading datagrams (of these lengths, all for one
/// destination) go out joined, in at most `max` bytes with the head (and
/// never more than one UDP payload): 1 when fewer than two fit, and the one
/// goes alone, without a head.
fn join_run(lengths: impl Iterator<Item = usize>, max: usize, framing: &Framing) -> usize {
    let max = max.min(MAX_DATAGRAM);
    let mut total = framing.base;
    let mut n = 0;
    for len in lengths {
        total += (framing.per_part)(len) + len;
        if n == MAX_JOINED || total > max {
            break;
        }
        n += 1;
    }
    n.max(1)
}

/// Datagrams that share one list of destinations, in order.
#[derive(Debug, Clone)]
struct Group {
    payloads: Range<usize>,
    dests: Range<usize>,
}

/// Which datagram goes to which destinations: the work of one
/// [`Sender::send`]. Datagrams are named by an index the caller resolves
/// when it sends (a slot of its receive batch, say), so a plan borrows
/// nothing and keeps its memory from one batch to the next.
///
/// Each destination gets its datagrams in the order they were pushed.
#[derive(Debug, Default)]
pub struct SendPlan {
    payloads: Vec<usize>,
    dests: Vec<SocketAddr>,
    /// Per destination: the most bytes of joined datagrams it takes (0: one
    /// datagram each).
    joins: Vec<usize>,
    #[cfg(target_os = "linux")]
    names: Vec<imp::Name>,
    groups: Vec<Group>,
    deliveries: usize,
}

impl SendPlan {
    /// An empty plan.
    pub fn new() -> SendPlan {
        SendPlan::default()
    }

    /// Empties the plan, keeping its memory.
    pub fn clear(&mut self) {
        self.payloads.clear();
        self.dests.clear();
        self.joins.clear();
        #[cfg(target_os = "linux")]
        self.names.clear();
        self.groups.clear();
        self.deliveries = 0;
    }

    /// Adds datagram `payload` (the caller's index) for each of `dests`.
    /// A datagram for the same destinations as the one pushed before it
    /// joins its group, which is what lets a run of them go out as one GSO
    /// message per destination.
    pub fn push(&mut self, payload: usize, dests: &[SocketAddr]) {
        self.push_joining(payload, dests, |_| 0);
    }

    /// Like [`push`](Self::push), where some destinations take several
    /// datagrams joined into one: `join_max(d)` is the most bytes destination
    /// `d` takes in one (0: one datagram each). It is asked only when a new
    /// list of destinations starts a group, so it may cost a lookup. A
    /// [`Sender`] without a [`Framing`] sends one datagram each anyway.
    pub fn push_joining(
        &mut self,
        payload: usize,
        dests: &[SocketAddr],
        join_max: impl Fn(&SocketAddr) -> usize,
    ) {
        if dests.is_empty() {
            return;
        }
        self.deliveries += dests.len();
        self.payloads.push(payload);
        if let Some(g) = self.groups.last_mut() {
            if self.dests[g.dests.clone()] == *dests {
                g.payloads.end += 1;
                return;
            }
        }
        let first = self.dests.len();
        self.dests.extend_from_slice(dests);
        self.joins.extend(dests.iter().map(join_max));
        #[cfg(target_os = "linux")]
        self.names.extend(dests.iter().map(imp::Name::new));
        self.groups.push(Group {
            payloads: self.payloads.len() - 1..self.payloads.len(),
            dests: first..self.dests.len(),
        });
    }

    /// How many deliveries the plan makes: each datagram once per
    /// destination, however they are joined on the way.
    pub fn deliveries(&self) -> usize {
        self.deliveries
    }

    /// Whether the plan sends nothing.
    pub fn is_empty(&self) -> bool {
        self.deliveries == 0
    }
}

/// Sends [`SendPlan`]s. It keeps its buffers from one send to the next and
/// writes only the entries each send uses; it remembers when the kernel
/// refused GSO, and sends runs that would have been GSO one datagram per
/// message from then on.
pub struct Sender {
    gso: bool,
    framing: Option<Framing>,
    #[cfg(target_os = "linux")]
    scratch: imp::Scratch,
}

impl Sender {
    /// A sender; with `gso`, runs of equal-length datagrams for one
    /// destination, and a shorter one after each, go out as one GSO message
    /// (Linux only; ignored elsewhere).
    pub fn new(gso: bool) -> Sender {
        Sender {
            gso: gso && cfg!(target_os = "linux"),
            framing: None,
            #[cfg(target_os = "linux")]
            scratch: imp::Scratch::default(),
        }
    }

    /// Joins datagrams this way for destinations that take them joined
    /// ([`SendPlan::push_joining`]).
    pub fn with_framing(mut self, framing: Framing) -> Sender {
        self.framing = Some(framing);
        self
    }

    /// Whether GSO is in use (it goes off for good when the kernel refuses it).
    pub fn gso(&self) -> bool {
        self.gso
    }

    /// Sends every delivery of `plan` without blocking, `payload(i)` giving
    /// the bytes of the datagram the plan calls `i`. A delivery the kernel
    /// refuses is dropped and counted, and the rest still go.
    pub fn send<'a>(
        &mut self,
        sock: &UdpSocket,
        plan: &SendPlan,
        payload: impl Fn(usize) -> &'a [u8],
    ) -> SendReport {
        if plan.is_empty() {
            return SendReport::default();
        }
        #[cfg(target_os = "linux")]
        {
            let framing = self.framing.as_ref();
            imp::send(
                &mut self.scratch,
                &mut self.gso,
                framing,
                sock,
                plan,
                payload,
            )
        }
        #[cfg(not(target_os = "linux"))]
        {
            let mut report = SendReport::default();
            let mut count = |n: usize, r: io::Result<usize>| match r {
                Ok(_) => report.sent += n,
                Err(e) if Loss::of(&e) == Loss::Full => report.full += n,
                Err(_) => report.failed += n,
            };
            for g in &plan.groups {
                let payloads = &plan.payloads[g.payloads.clone()];
                for d in g.dests.clone() {
                    let (dest, max) = (&plan.dests[d], plan.joins[d]);
                    let Some(framing) = self.framing.as_ref().filter(|_| max > 0) else {
                        for &p in payloads {
                            count(1, sock.send_to(payload(p), dest));
                        }
                        continue;
                    };
                    let mut i = 0;
                    while i < payloads.len() {
                        let rest = &payloads[i..];
                        let n = join_run(rest.iter().map(|&p| payload(p).len()), max, framing);
                        let r = if n == 1 {
                            sock.send_to(payload(rest[0]), dest)
                        } else {
                            let lengths: Vec<usize> =
                                rest[..n].iter().map(|&p| payload(p).len()).collect();
                            let mut joined = Vec::new();
                            (framing.write_head)(&lengths, &mut joined);
                            for &p in &rest[..n] {
                                joined.extend_from_slice(payload(p));
                            }
                            sock.send_to(&joined, dest)
                        };
                        count(n, r);
                        i += n;
                    }
                }
            }
            report
        }
    }
}

/// Repeats every datagram of a [`RecvBatch`] to a fixed list of
/// destinations with one [`Sender`]: what a perfect UDP hub could reach, for
/// the benchmarks' floor. With `gso`, each run of equal-length datagrams
/// (and a shorter one after it) goes out as one send per destination.
pub struct Repeater {
    dests: Vec<SocketAddr>,
    plan: SendPlan,
    sender: Sender,
}

impl Repeater {
    /// A repeater to `dests`.
    pub fn new(dests: &[SocketAddr], gso: bool) -> Repeater {
        Repeater {
            dests: dests.to_vec(),
            plan: SendPlan::new(),
            sender: Sender::new(gso),
        }
    }

    /// Sends the batch's datagrams to every destination, without blocking;
    /// a datagram the kernel refuses is dropped, as the hub does.
    pub fn repeat<const N: usize>(&mut self, sock: &UdpSocket, batch: &RecvBatch<N>) -> SendReport {
        self.plan.clear();
        for i in 0..batch.len() {
            self.plan.push(i, &self.dests);
        }
        self.sender.send(sock, &self.plan, |i| batch.get(i))
    }
}

#[cfg(target_os = "linux")]
mod imp {
    use super::*;
    use std::mem::{size_of, zeroed};
    use std::os::fd::AsRawFd;

    use crate::udp::imp::{send_all, sockaddr_in, sockaddr_in6};

    /// Bytes of the control message that carries `UDP_SEGMENT` (a u16):
    /// `CMSG_SPACE(2)` on 64-bit Linux.
    const CMSG_BYTES: usize = 24;
    /// `UDP_SEGMENT` from linux/udp.h.
    const UDP_SEGMENT: libc::c_int = 103;
    /// The most segments one GSO send may carry (`UDP_MAX_SEGMENTS` is 64
    /// on older kernels).
    const MAX_SEGMENTS: usize = 64;
    /// The longest datagram sent with GSO: one that fits a 1,500-byte link
    /// over IPv6. The kernel refuses segments longer than the path's MTU
    /// (`EINVAL`), which would turn GSO off for good; longer datagrams are
    /// rare on colony's links and go out one per message.
    const MAX_SEGMENT: usize = 1_452;

    /// A destination as the kernel reads it. `repr(C)` with the address
    /// first, so a pointer to a `Name` is a pointer to its sockaddr.
    #[derive(Clone, Copy)]
    #[repr(C)]
    pub(super) struct Name {
        // Read only by the kernel, through `msg_name`.
        #[allow(dead_code)]
        addr: Addr,
        len: libc::socklen_t,
    }

    #[derive(Clone, Copy)]
    #[repr(C)]
    union Addr {
        v4: libc::sockaddr_in,
        v6: libc::sockaddr_in6,
    }

    impl std::fmt::Debug for Name {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.debug_struct("Name").field("len", &self.len).finish()
        }
    }

    impl Name {
        pub(super) fn new(addr: &SocketAddr) -> Name {
            match addr {
                SocketAddr::V4(a) => Name {
                    addr: Addr { v4: sockaddr_in(a) },
                    len: size_of::<libc::sockaddr_in>() as libc::socklen_t,
                },
                SocketAddr::V6(a) => Name {
                    addr: Addr {
                        v6: sockaddr_in6(a),
                    },
                    len: size_of::<libc::sockaddr_in6>() as libc::socklen_t,
                },
            }
        }
    }

    /// One message of a send: a run of the plan's datagrams `first..end`
    /// (positions in `payloads`), all of one group.
    #[derive(Clone, Copy)]
    struct Unit {
        first: usize,
        end: usize,
        group: usize,
        /// `None`: as GSO segments (or alone), to each destination of the
        /// group that takes no joined datagrams. `Some(d)`: joined behind a
        /// head, to destination `d` alone; the head is `heads[head]` and the
        /// message's iovecs start at `joined[iov]`.
        joined: Option<usize>,
        head: (usize, usize),
        iov: usize,
    }

    /// The C structures one send hands the kernel, kept between sends.
    #[derive(Default)]
    pub(super) struct Scratch {
        iovs: Vec<libc::iovec>,
        hdrs: Vec<libc::mmsghdr>,
        /// How many datagrams each header carries, and whether as GSO segments.
        segments: Vec<(usize, bool)>,
        cmsgs: Vec<[u64; 4]>,
        units: Vec<Unit>,
        /// The heads of joined messages, back to back.
        heads: Vec<u8>,
        /// One head as it is written.
        head: Vec<u8>,
        /// Each joined message's iovecs: its head's, then its datagrams'.
        joined: Vec<libc::iovec>,
        lengths: Vec<usize>,
    }

    // SAFETY: the raw pointers inside `iovs`, `joined` and `hdrs` are
    // written at the start of each `send` and read only by the kernel during
    // it; between sends they are stale numbers that nothing dereferences. So
    // moving a `Scratch` to another thread shares nothing.
    unsafe impl Send for Scratch {}

    pub(super) fn send<'a>(
        s: &mut Scratch,
        gso: &mut bool,
        framing: Option<&Framing>,
        sock: &UdpSocket,
        plan: &SendPlan,
        payload: impl Fn(usize) -> &'a [u8],
    ) -> SendReport {
        s.iovs.clear();
        s.iovs.extend(plan.payloads.iter().map(|&p| {
            let d = payload(p);
            libc::iovec {
                iov_base: d.as_ptr() as *mut libc::c_void,
                iov_len: d.len(),
            }
        }));
        let (messages, runs) = plan_units(s, *gso, framing, plan);
        write_headers(s, framing, plan, messages, runs);
        transmit(s, gso, sock, plan, messages)
    }

    /// The framing of joined datagrams, if destination `d` takes them.
    fn joins<'f>(framing: Option<&'f Framing>, plan: &SendPlan, d: usize) -> Option<&'f Framing> {
        framing.filter(|_| plan.joins[d] > 0)
    }

    /// Cuts the plan into units, the messages the kernel is handed: returns how many messages
    /// they make and how many of them are GSO runs.
    fn plan_units(
        s: &mut Scratch,
        gso: bool,
        framing: Option<&Framing>,
        plan: &SendPlan,
    ) -> (usize, usize) {
        let joins = |d: usize| joins(framing, plan, d);
        // Units: one datagram each, or with GSO a run of datagrams of one
        // group (`gso_run`), which the kernel splits at delivery; then, for
        // each destination of the group that takes them, runs joined behind
        // a head (`join_run`).
        s.units.clear();
        s.heads.clear();
        let mut messages = 0;
        let mut runs = 0;
        let mut joined_iovs = 0;
        for (g, group) in plan.groups.iter().enumerate() {
            // Destinations that take no joined datagrams share the GSO runs.
            let plain = group.dests.clone().filter(|&d| joins(d).is_none()).count();
            let mut i = group.payloads.start;
            while plain > 0 && i < group.payloads.end {
                let end = if gso {
                    i + gso_run(&s.iovs[i..group.payloads.end])
                } else {
                    i + 1
                };
                if end - i > 1 {
                    runs += 1;
                }
                messages += plain;
                s.units.push(Unit {
                    first: i,
                    end,
                    group: g,
                    joined: None,
                    head: (0, 0),
                    iov: 0,
                });
                i = end;
            }
            for d in group.dests.clone() {
                let Some(framing) = joins(d) else { continue };
                let mut i = group.payloads.start;
                while i < group.payloads.end {
                    let lengths = s.iovs[i..group.payloads.end].iter().map(|v| v.iov_len);
                    let end = i + join_run(lengths, plan.joins[d], framing);
                    let head = if end - i > 1 {
                        s.lengths.clear();
                        s.lengths.extend(s.iovs[i..end].iter().map(|v| v.iov_len));
                        // Written apart and then appended: whatever the caller's
                        // function does to its vector, the heads already
                        // written keep their bytes and places.
                        s.head.clear();
                        (framing.write_head)(&s.lengths, &mut s.head);
                        debug_assert_eq!(
                            s.head.len(),
                            framing.base
                                + s.lengths
                                    .iter()
                                    .map(|&l| (framing.per_part)(l))
                                    .sum::<usize>(),
                            "a head's size differs from what its Framing says"
                        );
                        let start = s.heads.len();
                        s.heads.extend_from_slice(&s.head);
                        (start, s.heads.len())
                    } else {
                        (0, 0)
                    };
                    messages += 1;
                    s.units.push(Unit {
                        first: i,
                        end,
                        group: g,
                        joined: Some(d),
                        head,
                        iov: joined_iovs,
                    });
                    joined_iovs += 1 + (end - i);
                    i = end;
                }
            }
        }
        (messages, runs)
    }

    /// Writes a header for each message, pointing into the scratch buffers, which must not
    /// change again until the send.
    fn write_headers(
        s: &mut Scratch,
        framing: Option<&Framing>,
        plan: &SendPlan,
        messages: usize,
        runs: usize,
    ) {
        let joins = |d: usize| joins(framing, plan, d);
        // The joined messages' iovecs, now that no head moves any more: a
        // lone datagram goes without a head.
        s.joined.clear();
        let heads = s.heads.as_ptr();
        for u in &s.units {
            if u.joined.is_none() {
                continue;
            }
            s.joined.push(libc::iovec {
                iov_base: heads.wrapping_add(u.head.0) as *mut libc::c_void,
                iov_len: u.head.1 - u.head.0,
            });
            s.joined.extend_from_slice(&s.iovs[u.first..u.end]);
        }
        // Grow the buffers only; entries in use are written in full below.
        if s.hdrs.len() < messages {
            // SAFETY: all-zero is a valid mmsghdr (null pointers, zero lengths).
            s.hdrs.resize(messages, unsafe { zeroed() });
        }
        if s.cmsgs.len() < runs {
            s.cmsgs.resize(runs, [0; 4]);
        }
        let mut c = 0;
        for u in &s.units {
            if u.joined.is_none() && u.end - u.first > 1 {
                set_segment_size(&mut s.cmsgs[c], s.iovs[u.first].iov_len);
                c += 1;
            }
        }
        // Pointers are taken once, after every write to these vectors, and
        // offset with wrapping_add inside them.
        let iovs = s.iovs.as_mut_ptr();
        let joined = s.joined.as_mut_ptr();
        let cmsgs = s.cmsgs.as_mut_ptr();
        let names = plan.names.as_ptr();
        s.segments.clear();
        let (mut h, mut c) = (0, 0);
        for u in &s.units {
            let count = u.end - u.first;
            let mut fill = |d: usize, iov: *mut libc::iovec, iovlen: usize, control, gso: bool| {
                let m = &mut s.hdrs[h];
                m.msg_len = 0;
                let msg = &mut m.msg_hdr;
                // The kernel only reads the name on a send; a `Name` starts
                // with its sockaddr.
                msg.msg_name = names.wrapping_add(d) as *mut libc::c_void;
                msg.msg_namelen = plan.names[d].len;
                // The kernel reads `iovlen` iovecs from here.
                msg.msg_iov = iov;
                msg.msg_iovlen = iovlen;
                msg.msg_control = control;
                msg.msg_controllen = if control.is_null() { 0 } else { CMSG_BYTES };
                msg.msg_flags = 0;
                s.segments.push((count, gso));
                h += 1;
            };
            match u.joined {
                Some(d) if count > 1 => {
                    fill(
                        d,
                        joined.wrapping_add(u.iov),
                        1 + count,
                        std::ptr::null_mut(),
                        false,
                    );
                }
                // Alone: past the empty head.
                Some(d) => fill(
                    d,
                    joined.wrapping_add(u.iov + 1),
                    1,
                    std::ptr::null_mut(),
                    false,
                ),
                None => {
                    let control = if count > 1 {
                        c += 1;
                        cmsgs.wrapping_add(c - 1).cast::<libc::c_void>()
                    } else {
                        std::ptr::null_mut()
                    };
                    for d in plan.groups[u.group].dests.clone() {
                        if joins(d).is_none() {
                            fill(d, iovs.wrapping_add(u.first), count, control, count > 1);
                        }
                    }
                }
            }
        }
    }

    /// Hands the kernel the headers written, and counts what it refused.
    fn transmit(
        s: &mut Scratch,
        gso: &mut bool,
        sock: &UdpSocket,
        plan: &SendPlan,
        messages: usize,
    ) -> SendReport {
        let mut report = SendReport::default();
        let segments = &s.segments;
        let fd = sock.as_raw_fd();
        send_all(fd, &mut s.hdrs[..messages], |k, hdr, e| {
            let (n, as_gso) = segments.get(k).copied().unwrap_or((1, false));
            let refused_gso = matches!(e.raw_os_error(), Some(libc::EIO | libc::EINVAL));
            if as_gso && refused_gso {
                // This path (its device, or its MTU) takes no GSO: send the
                // run one datagram at a time, and never try GSO again.
                *gso = false;
                one_by_one(fd, hdr, &mut report);
            } else {
                match Loss::of(&e) {
                    Loss::Full => report.full += n,
                    Loss::Failed => report.failed += n,
                }
            }
            true
        });
        report.sent = plan.deliveries - report.full - report.failed;
        report
    }

    /// How many of the leading datagrams of `iovs` (all for one destination)
    /// go out as one GSO message: a run of equal lengths, and after it one
    /// shorter datagram, since the kernel cuts a GSO payload every segment's
    /// length and the last piece may be shorter. In a stream whose lengths
    /// differ from packet to packet (uniform in 60 to 400 bytes) that puts
    /// about three datagrams in four into pairs, and cuts the messages by a
    /// third. At least 1 (0 only for no datagrams); 1 for a datagram too long
    /// to be a segment.
    pub(super) fn gso_run(iovs: &[libc::iovec]) -> usize {
        let Some(len) = iovs.first().map(|v| v.iov_len) else {
            return 0;
        };
        if !(1..=MAX_SEGMENT).contains(&len) {
            return 1;
        }
        let mut n = 1;
        while n < iovs.len()
            && iovs[n].iov_len == len
            && n < MAX_SEGMENTS
            && (n + 1) * len <= MAX_DATAGRAM
        {
            n += 1;
        }
        if n < iovs.len() && n < MAX_SEGMENTS {
            let short = iovs[n].iov_len;
            if (1..len).contains(&short) && n * len + short <= MAX_DATAGRAM {
                n += 1;
            }
        }
        n
    }

    /// Sends each datagram of a GSO message on its own.
    fn one_by_one(fd: libc::c_int, hdr: &libc::mmsghdr, report: &mut SendReport) {
        for i in 0..hdr.msg_hdr.msg_iovlen {
            // SAFETY: all-zero is a valid msghdr; the fields set point where
            // `hdr`'s do (its name, one of its iovecs), which `send` keeps
            // alive and which the kernel only reads.
            let mut msg: libc::msghdr = unsafe { zeroed() };
            msg.msg_name = hdr.msg_hdr.msg_name;
            msg.msg_namelen = hdr.msg_hdr.msg_namelen;
            msg.msg_iov = hdr.msg_hdr.msg_iov.wrapping_add(i);
            msg.msg_iovlen = 1;
            loop {
                // SAFETY: `msg` is a valid header as said above, and the
                // descriptor is the borrowed socket's.
                let r = unsafe { libc::sendmsg(fd, &msg, libc::MSG_DONTWAIT) };
                if r >= 0 {
                    break;
                }
                let e = io::Error::last_os_error();
                if e.kind() == io::ErrorKind::Interrupted {
                    continue;
                }
                match Loss::of(&e) {
                    Loss::Full => report.full += 1,
                    Loss::Failed => report.failed += 1,
                }
                break;
            }
        }
    }

    /// Writes a `UDP_SEGMENT` control message for segments of `size` bytes.
    fn set_segment_size(buf: &mut [u64; 4], size: usize) {
        // SAFETY: CMSG_SPACE is a pure computation.
        debug_assert_eq!(unsafe { libc::CMSG_SPACE(2) } as usize, CMSG_BYTES);
        // SAFETY: `buf` is 32 bytes, 8-byte aligned, which holds one cmsghdr
        // (16 bytes) and its 2 data bytes; the header is written through the
        // pointer CMSG_FIRSTHDR gives for a msghdr describing exactly `buf`
        // (never null: CMSG_BYTES is at least a cmsghdr), and the data with
        // an unaligned write.
        unsafe {
            let mut msg: libc::msghdr = zeroed();
            msg.msg_control = buf.as_mut_ptr().cast();
            msg.msg_controllen = CMSG_BYTES;
            let c = libc::CMSG_FIRSTHDR(&msg);
            (*c).cmsg_level = libc::SOL_UDP;
            (*c).cmsg_type = UDP_SEGMENT;
            (*c).cmsg_len = libc::CMSG_LEN(2) as usize;
            std::ptr::write_unaligned(libc::CMSG_DATA(c).cast::<u16>(), size as u16);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn socket() -> UdpSocket {
        let s = UdpSocket::bind("127.0.0.1:0").unwrap();
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        s
    }

    /// Whether datagram `i` goes to every destination: all but ten in each
    /// fifty, which skip the first, so the plan's groups change.
    fn to_all(i: usize) -> bool {
        i % 50 < 40
    }

    /// The datagrams that went to every destination.
    fn sent_to_all(data: &[Vec<u8>]) -> Vec<Vec<u8>> {
        (0..data.len())
            .filter(|&i| to_all(i))
            .map(|i| data[i].clone())
            .collect()
    }

    /// A sending socket, `n` receiving ones and their addresses.
    fn sockets(n: usize) -> (UdpSocket, Vec<UdpSocket>, Vec<SocketAddr>) {
        let subs: Vec<UdpSocket> = (0..n).map(|_| socket()).collect();
        let addrs = subs.iter().map(|s| s.local_addr().unwrap()).collect();
        (socket(), subs, addrs)
    }

    fn read(s: &UdpSocket, n: usize) -> Vec<Vec<u8>> {
        (0..n)
            .map(|_| {
                let mut buf = [0; 2048];
                let len = s.recv(&mut buf).unwrap();
                buf[..len].to_vec()
            })
            .collect()
    }

    #[test]
    fn a_full_buffer_is_told_apart_from_other_refusals() {
        let e = |n| io::Error::from_raw_os_error(n);
        assert_eq!(Loss::of(&e(libc::EAGAIN)), Loss::Full);
        assert_eq!(Loss::of(&e(libc::EWOULDBLOCK)), Loss::Full);
        assert_eq!(Loss::of(&e(libc::ENOBUFS)), Loss::Full);
        assert_eq!(Loss::of(&e(libc::ECONNREFUSED)), Loss::Failed);
        assert_eq!(Loss::of(&e(libc::ENETUNREACH)), Loss::Failed);
        assert_eq!(Loss::of(&e(libc::EINVAL)), Loss::Failed);
    }

    #[test]
    fn each_destination_gets_its_datagrams_in_order_with_and_without_gso() {
        for gso in [false, true] {
            let (from, subs, a) = sockets(3);
            // Runs of equal lengths, a change of lengths, and a change of
            // destinations between them.
            let data: Vec<Vec<u8>> = (0..200u8)
                .map(|i| vec![i; if i < 100 { 20 } else { 20 + usize::from(i % 3) }])
                .collect();
            let mut plan = SendPlan::new();
            for i in 0..data.len() {
                if to_all(i) {
                    plan.push(i, &a);
                } else {
                    plan.push(i, &a[1..]);
                }
            }
            let mut sender = Sender::new(gso);
            let report = sender.send(&from, &plan, |i| &data[i]);
            assert_eq!(report.sent, plan.deliveries(), "gso {gso}");
            // Loopback takes GSO: it was not turned off on the way.
            assert_eq!(sender.gso(), gso);
            let only_first = sent_to_all(&data);
            assert_eq!(read(&subs[0], only_first.len()), only_first, "gso {gso}");
            for s in &subs[1..] {
                assert_eq!(read(s, data.len()), data, "gso {gso}");
            }
        }
    }

    /// The sizes of the GSO messages `gso_run` cuts datagrams of `lengths` into.
    fn runs_of(lengths: &[usize]) -> Vec<usize> {
        let iovs: Vec<libc::iovec> = lengths
            .iter()
            .map(|&n| libc::iovec {
                iov_base: std::ptr::null_mut(),
                iov_len: n,
            })
            .collect();
        let mut runs = Vec::new();
        let mut i = 0;
        while i < iovs.len() {
            let n = imp::gso_run(&iovs[i..]);
            runs.push(n);
            i += n;
        }
        runs
    }

    #[test]
    fn a_gso_run_is_equal_lengths_then_at_most_one_shorter() {
        // Equal lengths, then a shorter one closes the run.
        assert_eq!(runs_of(&[100, 100, 100, 60, 60]), [4, 1]);
        // A longer one starts a run of its own; so does anything after the shorter one.
        assert_eq!(runs_of(&[60, 100, 100, 60, 59]), [1, 3, 1]);
        // Lengths that differ from packet to packet pair where they fall.
        assert_eq!(runs_of(&[300, 200, 100, 400, 399, 398]), [2, 1, 2, 1]);
        // Nothing empty is a segment, and nothing too long for one.
        assert_eq!(runs_of(&[100, 0, 100]), [1, 1, 1]);
        assert_eq!(runs_of(&[2000, 2000, 10]), [1, 1, 1]);
        // At most 64 segments, the shorter one included.
        assert_eq!(runs_of(&[[10; 64].as_slice(), &[5]].concat()), [64, 1]);
        assert_eq!(runs_of(&[[10; 63].as_slice(), &[5, 5]].concat()), [64, 1]);
        // At most one IPv4 datagram of payload: 45 segments of 1,452 bytes
        // fill 65,340 of 65,507; a 168-byte tail would pass the limit.
        assert_eq!(runs_of(&[[1452; 45].as_slice(), &[168]].concat()), [45, 1]);
        assert_eq!(runs_of(&[[1452; 45].as_slice(), &[167]].concat()), [46]);
    }

    #[test]
    fn datagrams_of_differing_lengths_arrive_whole_and_in_order() {
        for gso in [false, true] {
            let (from, subs, a) = sockets(2);
            // Lengths from 1 to 400 in a scrambled order, with equal runs
            // and one-byte tails among them.
            let mut lengths: Vec<usize> = (0..150).map(|i| 1 + (i * 97) % 400).collect();
            lengths.extend([50, 50, 50, 1, 7, 7, 6, 400, 1]);
            let data: Vec<Vec<u8>> = lengths
                .iter()
                .enumerate()
                .map(|(i, &n)| (0..n).map(|k| (i + k) as u8).collect())
                .collect();
            let mut plan = SendPlan::new();
            for i in 0..data.len() {
                plan.push(i, &a);
            }
            let mut sender = Sender::new(gso);
            let report = sender.send(&from, &plan, |i| &data[i]);
            assert_eq!(report.sent, plan.deliveries(), "gso {gso}");
            assert_eq!(sender.gso(), gso);
            for s in &subs {
                assert_eq!(read(s, data.len()), data, "gso {gso}");
            }
        }
    }

    #[test]
    fn a_plan_larger_than_one_system_call_is_sent_whole() {
        let (from, subs, dests) = sockets(11);
        let data: Vec<Vec<u8>> = (0..100u32).map(|i| i.to_be_bytes().to_vec()).collect();
        let mut plan = SendPlan::new();
        for i in 0..data.len() {
            plan.push(i, &dests);
        }
        // Without GSO each delivery is a message: 1,100, more than one
        // sendmmsg takes (UIO_MAXIOV, 1,024); 100 small datagrams fit a
        // default receive buffer.
        let mut sender = Sender::new(false);
        let report = sender.send(&from, &plan, |i| &data[i]);
        assert_eq!(report.sent, 1100);
        for s in &subs {
            assert_eq!(read(s, 100), data);
        }
    }

    #[test]
    fn a_refused_destination_is_counted_and_the_rest_still_go() {
        let from = socket();
        let to = socket();
        // Port 0 is no destination: the kernel refuses it (EINVAL).
        let dests = ["127.0.0.1:0".parse().unwrap(), to.local_addr().unwrap()];
        let mut plan = SendPlan::new();
        plan.push(0, &dests);
        let mut sender = Sender::new(true);
        let report = sender.send(&from, &plan, |_| b"hello");
        assert_eq!(report.failed, 1);
        assert_eq!(report.sent, 1);
        assert_eq!(read(&to, 1), [b"hello".to_vec()]);
    }

    /// A framing for the tests: a count byte, then each length as two bytes.
    const TEST_FRAMING: Framing = Framing {
        base: 1,
        per_part: |_| 2,
        write_head: |lengths, out| {
            out.push(lengths.len() as u8);
            for &l in lengths {
                out.extend_from_slice(&(l as u16).to_be_bytes());
            }
        },
    };

    /// Cuts a datagram joined with [`TEST_FRAMING`]; `None` if it is one alone.
    fn unjoin(d: &[u8]) -> Vec<Vec<u8>> {
        let n = usize::from(d[0]);
        let mut at = 1 + 2 * n;
        (0..n)
            .map(|i| {
                let len = usize::from(u16::from_be_bytes([d[1 + 2 * i], d[2 + 2 * i]]));
                at += len;
                d[at - len..at].to_vec()
            })
            .collect()
    }

    #[test]
    fn a_destination_that_joins_gets_its_datagrams_joined_and_the_rest_one_each() {
        for gso in [false, true] {
            let (from, subs, a) = sockets(3);
            // Datagrams that start with 0xff, so none is taken for a head;
            // one too long to join with any other goes alone.
            let data: Vec<Vec<u8>> = (0..150u8)
                .map(|i| {
                    let len = if i == 17 {
                        250
                    } else {
                        20 + usize::from(i % 7)
                    };
                    [vec![0xff], vec![i; len]].concat()
                })
                .collect();
            let mut plan = SendPlan::new();
            for i in 0..data.len() {
                // A change of destinations splits the joined runs.
                let dests = if to_all(i) { &a[..] } else { &a[1..] };
                plan.push_joining(i, dests, |d| if *d == a[2] { 200 } else { 0 });
            }
            let mut sender = Sender::new(gso).with_framing(TEST_FRAMING);
            let report = sender.send(&from, &plan, |i| &data[i]);
            assert_eq!(report.sent, plan.deliveries(), "gso {gso}");
            let only_first = sent_to_all(&data);
            assert_eq!(read(&subs[0], only_first.len()), only_first, "gso {gso}");
            assert_eq!(read(&subs[1], data.len()), data, "gso {gso}");
            // The third gets every datagram, in order, in fewer datagrams,
            // none over its 200 bytes.
            let mut got = Vec::new();
            let (mut datagrams, mut alone) = (0, 0);
            while got.len() < data.len() {
                let d = read(&subs[2], 1).remove(0);
                datagrams += 1;
                if d[0] == 0xff {
                    alone += 1;
                    got.push(d);
                } else {
                    assert!(d.len() <= 200, "{} bytes joined", d.len());
                    got.extend(unjoin(&d));
                }
            }
            assert_eq!(got, data, "gso {gso}");
            assert!(alone >= 1, "the long datagram was joined");
            assert!(datagrams <= data.len() / 5, "{datagrams} datagrams");
        }
    }

    #[test]
    fn joining_fills_each_datagram_up_to_the_limit_and_no_further() {
        let lengths = [10, 10, 10, 10];
        // Head 1 + 2 a datagram: two fit in 1 + 24 bytes, three in 37.
        assert_eq!(join_run(lengths.iter().copied(), 25, &TEST_FRAMING), 2);
        assert_eq!(join_run(lengths.iter().copied(), 36, &TEST_FRAMING), 2);
        assert_eq!(join_run(lengths.iter().copied(), 37, &TEST_FRAMING), 3);
        assert_eq!(join_run(lengths.iter().copied(), 65_507, &TEST_FRAMING), 4);
        // Too long to join: alone.
        assert_eq!(join_run([100, 10].into_iter(), 50, &TEST_FRAMING), 1);
        // Never past one UDP payload, whatever the destination asked.
        assert_eq!(
            join_run([40_000, 40_000].into_iter(), usize::MAX, &TEST_FRAMING),
            1
        );
        assert_eq!(
            join_run(std::iter::repeat_n(1, 5000), usize::MAX, &TEST_FRAMING),
            1023
        );
    }

    #[test]
    fn without_a_framing_a_joining_destination_gets_one_datagram_each() {
        let from = socket();
        let to = socket();
        let dest = [to.local_addr().unwrap()];
        let data: Vec<Vec<u8>> = (0..5u8).map(|i| vec![i; 10]).collect();
        let mut plan = SendPlan::new();
        for i in 0..data.len() {
            plan.push_joining(i, &dest, |_| 1000);
        }
        let report = Sender::new(false).send(&from, &plan, |i| &data[i]);
        assert_eq!(report.sent, 5);
        assert_eq!(read(&to, 5), data);
    }

    #[test]
    fn a_kernel_that_refuses_gso_gets_each_datagram_alone_from_then_on() {
        let from = socket();
        // Linux refuses GSO on a socket that sends without UDP checksums
        // (EINVAL), as a device without checksum offload would (EIO).
        let on: libc::c_int = 1;
        // SAFETY: `on` is a live c_int and the length passed is its size,
        // as SO_NO_CHECK reads; the socket is open.
        let r = unsafe {
            libc::setsockopt(
                std::os::fd::AsRawFd::as_raw_fd(&from),
                libc::SOL_SOCKET,
                libc::SO_NO_CHECK,
                (&on as *const libc::c_int).cast(),
                std::mem::size_of::<libc::c_int>() as libc::socklen_t,
            )
        };
        assert_eq!(r, 0);
        let to = socket();
        let dest = [to.local_addr().unwrap()];
        // Equal lengths and a shorter tail: one GSO message, refused, then each datagram.
        let data: Vec<Vec<u8>> = (0..10u8)
            .map(|i| vec![i; if i == 9 { 12 } else { 30 }])
            .collect();
        let mut plan = SendPlan::new();
        for i in 0..data.len() {
            plan.push(i, &dest);
        }
        let mut sender = Sender::new(true);
        let report = sender.send(&from, &plan, |i| &data[i]);
        assert_eq!(report.sent, 10);
        assert!(!sender.gso(), "GSO still on after the kernel refused it");
        assert_eq!(read(&to, 10), data);
        // And the next send goes without trying GSO.
        let report = sender.send(&from, &plan, |i| &data[i]);
        assert_eq!(report.sent, 10);
        assert_eq!(read(&to, 10), data);
    }
}
