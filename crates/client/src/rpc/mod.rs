//! Request and reply over publish/subscribe (the Broker paper, III.E): a
//! provider publishes its existence on a service's channel, callers send
//! each call to one live provider's inbox and get its answer in their own.
//!
//! [`Caller`] and [`Provider`] are the protocol alone, sans I/O, like
//! [`Session`](crate::Session); [`CallClient`] and [`ServeClient`] put a
//! [`UdpClient`](crate::UdpClient) under each, for programs that just want
//! to call or serve. The packets are in [`message`]; [`runner`] serves a
//! service with a program, one process a call.
//!
//! What a caller can count on: every call ends exactly once, with the
//! answer of a provider it was sent to, proven by that provider's seal, or
//! with a [`CallError`] that says why not (no provider, the deadline, the
//! provider leaving or falling silent for its lease, a refusal). A provider
//! that does not say `accepted` within the ack wait is passed over for the
//! next; once one accepts, the call is never sent elsewhere (it may act on
//! it), and a lost answer is a timeout.

mod caller;
mod endpoint;
pub mod message;
mod provider;
pub mod runner;
#[cfg(test)]
mod tests;

use std::fmt;
use std::time::Duration;

pub use caller::{Answer, Caller, Outcome, ACK_WAIT};
pub use endpoint::{Asked, CallClient, ServeClient};
pub use message::{Id, Said, Service};
pub use provider::{Call, Provider, Ticket};

/// The longest provider lease a caller believes: a forged announcement
/// holds a place among its providers for at most this long.
const LONGEST_LEASE: Duration = Duration::from_secs(60);
/// The longest a call may wait for its answer.
pub const LONGEST_TIMEOUT: Duration = Duration::from_secs(86_400);

/// Why a call ended without an answer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CallError {
    /// No provider announced itself before the deadline.
    NoProvider {
        /// How long the call waited.
        waited: Duration,
    },
    /// The provider did not answer before the deadline (or none of those
    /// tried took the call).
    Timeout {
        /// The provider that took the call, or the last one tried.
        provider: Id,
        /// How long the call waited.
        waited: Duration,
    },
    /// The provider said it was stopping, and its lease lapsed before it answered.
    ProviderLeft {
        /// The provider.
        provider: Id,
    },
    /// The provider fell silent for longer than its lease (it died, or lost the hub).
    ProviderLapsed {
        /// The provider.
        provider: Id,
        /// Its lease.
        lease: Duration,
        /// How long it had been silent.
        silent: Duration,
    },
    /// The provider could not serve the call.
    Refused {
        /// The provider.
        provider: Id,
        /// Its reason.
        why: String,
    },
    /// The call could not be written as a packet to the provider chosen.
    Unsendable(String),
}

impl fmt::Display for CallError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CallError::NoProvider { waited } => write!(
                f,
                "no provider of the service answered within {:.1} s (is one running on this hub?)",
                waited.as_secs_f64()
            ),
            CallError::Timeout { provider, waited } => write!(
                f,
                "provider {provider} did not answer within {:.1} s",
                waited.as_secs_f64()
            ),
            CallError::ProviderLeft { provider } => {
                write!(f, "provider {provider} stopped before answering")
            }
            CallError::ProviderLapsed {
                provider,
                lease,
                silent,
            } => write!(
                f,
                "provider {provider} fell silent for {:.1} s, past its {:.1} s lease, before answering",
                silent.as_secs_f64(),
                lease.as_secs_f64()
            ),
            CallError::Refused { provider, why } => {
                write!(f, "provider {provider} refused the call: {why}")
            }
            CallError::Unsendable(why) => write!(f, "the call cannot be sent: {why}"),
        }
    }
}

impl std::error::Error for CallError {}

/// What stops a caller or provider from working at all.
#[derive(Debug, thiserror::Error)]
pub enum RpcError {
    /// A service name that cannot make a channel.
    #[error(
        "`{0}` cannot name a service: use letters, digits and `_-.:/`, 1 to {max} bytes",
        max = message::MAX_SERVICE_LEN
    )]
    BadService(String),
    /// A call's timeout that is zero or longer than [`LONGEST_TIMEOUT`].
    #[error("a call's timeout must be more than 0 and at most a day, not {0:?}")]
    BadTimeout(Duration),
    /// Lines that do not make a valid packet (numbered from the call's first line).
    #[error("the call's lines are not a valid packet: {0}")]
    BadLines(colony_wire::ParseError),
    /// The call ended without an answer.
    #[error(transparent)]
    Call(#[from] CallError),
    /// The hub's address or the socket.
    #[error(transparent)]
    Client(#[from] crate::ClientError),
    /// The hub's address could not be resolved.
    #[error(transparent)]
    Connect(#[from] crate::ConnectError),
    /// The socket failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}
