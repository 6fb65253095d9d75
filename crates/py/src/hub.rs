//! Publishing an environment's packets to a hub, for `render_mode="human"`:
//! colony's monitor (and `colony spy`, and any subscriber) then shows a Python
//! run live, exactly as it shows `colony sort live` or a live match.

use std::time::Instant;

use colony_client::{ClientError, UdpClient};
use pyo3::exceptions::{PyConnectionError, PyValueError};
use pyo3::prelude::*;

/// A hub client that only publishes. Datagrams are fire and forget: a hub that
/// is not running loses the frames and the environment carries on.
#[pyclass(module = "colony._native")]
pub struct Publisher {
    client: UdpClient,
    sent: u64,
}

#[pymethods]
impl Publisher {
    /// A publisher to the hub at `hub` (`HOST:PORT`).
    #[new]
    fn new(hub: &str) -> PyResult<Publisher> {
        let client =
            UdpClient::connect_to(hub).map_err(|e| PyConnectionError::new_err(e.to_string()))?;
        Ok(Publisher { client, sent: 0 })
    }

    /// Publishes each packet; a malformed one is refused with its position.
    fn publish(&mut self, packets: Vec<Vec<u8>>) -> PyResult<()> {
        let now = Instant::now();
        self.client
            .poll(now)
            .map_err(|e| PyConnectionError::new_err(e.to_string()))?;
        // Nothing is subscribed, but the hub answers refreshes: read them so the
        // socket's buffer never fills.
        while let Ok(Some(_)) = self.client.recv_any() {}
        for p in &packets {
            self.client.publish(p).map_err(|e| match e {
                ClientError::Io(_) | ClientError::Address { .. } => {
                    PyConnectionError::new_err(e.to_string())
                }
                // The parser's verdict says where: keep it in the message.
                ClientError::Malformed(why) => {
                    PyValueError::new_err(format!("refusing to publish a malformed packet: {why}"))
                }
                other => PyValueError::new_err(other.to_string()),
            })?;
            self.sent += 1;
        }
        Ok(())
    }

    /// Packets published so far.
    #[getter]
    fn sent(&self) -> u64 {
        self.sent
    }

    /// The hub's address, resolved.
    #[getter]
    fn hub(&self) -> String {
        self.client.hub_addr().to_string()
    }
}
