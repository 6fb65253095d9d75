//! What the web side sends the hub side: a page's command, with where its answer goes. Its
//! own module because both the pages' server and the Foxglove endpoint send them, and the
//! hub side that answers them also feeds the endpoint.

use tokio::sync::oneshot;

use crate::state::{Command, CommandError, PageId};

/// A browser's request on its way to the bridge: the page it came from, and where the answer goes.
pub type Envelope = (
    PageId,
    Command,
    oneshot::Sender<Result<String, CommandError>>,
);
