//! Keys for the state machines' tests: each name seals with one key of its
//! own for the whole test, as one process would.

use std::cell::RefCell;
use std::collections::HashMap;

use colony_wire::seal::{Identity, PublicKey};

use crate::protocol::{Negotiation, Token};

thread_local! {
    static KEYS: RefCell<HashMap<String, Identity>> = RefCell::new(HashMap::new());
}

/// `packet` sealed by the process called `name`.
pub(crate) fn seal_as(name: &str, packet: Vec<u8>) -> Vec<u8> {
    KEYS.with(|keys| {
        let mut keys = keys.borrow_mut();
        let id = keys
            .entry(name.to_owned())
            .or_insert_with(|| identity_for(name));
        id.sealed(packet)
    })
}

/// The public key `name` seals with.
#[allow(dead_code)]
pub(crate) fn key_of(name: &str) -> PublicKey {
    identity_for(name).public()
}

fn identity_for(name: &str) -> Identity {
    let mut seed = [0u8; 32];
    for (s, b) in seed.iter_mut().zip(name.bytes().cycle()) {
        *s = b;
    }
    seed[31] = name.len() as u8;
    Identity::from_seed(seed)
}

/// Who says a negotiation message: the bidder it names, or else the
/// task's announcer.
pub(crate) fn speaker<'a>(m: &'a Negotiation, announcer: &'a Token) -> &'a str {
    match m {
        Negotiation::Bid(b) => b.bidder.as_str(),
        Negotiation::Ack { bidder, .. }
        | Negotiation::Decline { bidder, .. }
        | Negotiation::Done { bidder, .. }
        | Negotiation::Abandon { bidder, .. } => bidder.as_str(),
        Negotiation::Renew { by, .. } => by.as_str(),
        Negotiation::Award { .. }
        | Negotiation::Cancel { .. }
        | Negotiation::Unachievable { .. } => announcer.as_str(),
    }
}
