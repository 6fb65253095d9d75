//! What the hub counts: traffic per channel and drops by reason.

use std::collections::HashMap;

/// Why the hub dropped a datagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DropReason {
    /// Not a well-formed packet.
    Malformed,
    /// Published below the minimum priority.
    BelowMinPriority,
    /// A packet to `<hub>` that is no valid request.
    BadControl,
    /// A subscription from a new address while the hub holds its maximum of clients.
    TooManyClients,
    /// A subscription beyond the per-client maximum.
    TooManySubscriptions,
    /// The socket would not take a datagram for one subscriber (a send
    /// buffer was full: the kernel said `EAGAIN` or `ENOBUFS`).
    SendFull,
    /// A send to one subscriber failed for another reason (its port was
    /// closed, its network unreachable).
    SendFailed,
    /// Datagrams the kernel dropped before the hub read them, because the
    /// hub's receive buffer was full (`SO_RXQ_OVFL`).
    ReceiveOverflow,
    /// A source that can be no client: the hub's own address, port 0, a
    /// broadcast, multicast or unspecified address. Never answered.
    BadSource,
    /// A source outside the hub's `--allow` ranges.
    NotAllowed,
    /// A request that acts on other clients (`min_priority`) from a source
    /// that is no console.
    NotConsole,
    /// A packet whose authentication line was missing, wrong or replayed.
    BadAuth,
    /// A subscription whose cookie did not match its source (forged, or
    /// from an earlier epoch); answered with a fresh cookie.
    BadCookie,
    /// More requests from one source than its rate allows.
    RateLimited,
    /// A tap asked for while the hub already has its most taps.
    TooManyTaps,
    /// A request from a source not yet proven (with no cookie, or a wrong
    /// one) too short to be answered with a cookie: the answer would be more
    /// bytes than the request, which a forger could aim at anyone.
    Unproven,
}

impl DropReason {
    /// Every reason, in the order status reports list them.
    pub const ALL: [DropReason; 16] = [
        DropReason::Malformed,
        DropReason::BelowMinPriority,
        DropReason::BadControl,
        DropReason::TooManyClients,
        DropReason::TooManySubscriptions,
        DropReason::SendFull,
        DropReason::SendFailed,
        DropReason::ReceiveOverflow,
        DropReason::BadSource,
        DropReason::NotAllowed,
        DropReason::NotConsole,
        DropReason::BadAuth,
        DropReason::BadCookie,
        DropReason::RateLimited,
        DropReason::TooManyTaps,
        DropReason::Unproven,
    ];

    /// The reason's name in status reports.
    pub fn name(self) -> &'static str {
        match self {
            DropReason::Malformed => "malformed",
            DropReason::BelowMinPriority => "below_min_priority",
            DropReason::BadControl => "bad_control",
            DropReason::TooManyClients => "too_many_clients",
            DropReason::TooManySubscriptions => "too_many_subscriptions",
            DropReason::SendFull => "send_full",
            DropReason::SendFailed => "send_failed",
            DropReason::ReceiveOverflow => "receive_overflow",
            DropReason::BadSource => "bad_source",
            DropReason::NotAllowed => "not_allowed",
            DropReason::NotConsole => "not_console",
            DropReason::BadAuth => "bad_auth",
            DropReason::BadCookie => "bad_cookie",
            DropReason::RateLimited => "rate_limited",
            DropReason::TooManyTaps => "too_many_taps",
            DropReason::Unproven => "unproven",
        }
    }
}

/// Counters whose memory stays bounded whatever subjects arrive.
#[derive(Debug, Default)]
pub(crate) struct Counters {
    drops: [u64; DropReason::ALL.len()],
    channels: HashMap<Box<str>, (u64, u64)>,
    other: (u64, u64),
}

pub(crate) const OTHER_CHANNELS: &str = "*other*";

impl Counters {
    pub(crate) fn drop(&mut self, reason: DropReason, n: u64) {
        self.drops[reason as usize] += n;
    }

    pub(crate) fn drops(&self, reason: DropReason) -> u64 {
        self.drops[reason as usize]
    }

    pub(crate) fn published(&mut self, subjects: &str, bytes: usize, max_channels: usize) {
        let bump = |slot: &mut (u64, u64)| {
            slot.0 += 1;
            slot.1 += bytes as u64;
        };
        if let Some(slot) = self.channels.get_mut(subjects) {
            return bump(slot);
        }
        if self.channels.len() < max_channels {
            bump(self.channels.entry(subjects.into()).or_default());
        } else {
            bump(&mut self.other);
        }
    }

    /// Per-channel `(name, packets, bytes)`, busiest first.
    pub(crate) fn channels(&self) -> Vec<(String, u64, u64)> {
        let mut all: Vec<_> = self
            .channels
            .iter()
            .map(|(k, &(p, b))| (k.to_string(), p, b))
            .collect();
        if self.other.0 > 0 {
            all.push((OTHER_CHANNELS.to_owned(), self.other.0, self.other.1));
        }
        all.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        all
    }
}
