//! What the web side sends the hub side: a page's command, with where its answer goes. Its
//! own module because both the pages' server and the Foxglove endpoint's viewers send them, and
//! the hub side that answers them also feeds the endpoint.

use std::sync::mpsc::{SyncSender, TrySendError};
use std::time::Duration;

use tokio::sync::oneshot;

use crate::state::{Command, CommandError, PageId};

/// A browser's request on its way to the bridge: the page it came from, and where the answer goes.
pub type Envelope = (
    PageId,
    Command,
    oneshot::Sender<Result<String, CommandError>>,
);

/// Hands one command of `page` to the hub link and waits for its answer: what was done, or
/// why not, for the operator to read.
pub(crate) async fn carry_out(
    requests: &SyncSender<Envelope>,
    page: PageId,
    command: Command,
) -> Result<String, String> {
    let (tx, rx) = oneshot::channel();
    match requests.try_send((page, command, tx)) {
        Ok(()) => {}
        Err(TrySendError::Full(_)) => return Err("the monitor is busy; try again".into()),
        Err(TrySendError::Disconnected(_)) => return Err("the monitor is stopping".into()),
    }
    match tokio::time::timeout(Duration::from_secs(2), rx).await {
        Ok(Ok(Ok(msg))) => Ok(msg),
        Ok(Ok(Err(e))) => Err(e.to_string()),
        Ok(Err(_)) => Err("the monitor is stopping".into()),
        Err(_) => Err("no answer from the hub bridge within 2 s".into()),
    }
}
