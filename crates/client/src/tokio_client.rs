//! The client under tokio: [`UdpClient`] in an `AsyncFd`, timers on tokio's clock.

use std::io;
use std::time::Instant;

use tokio::io::unix::AsyncFd;

use crate::{ClientError, UdpClient};

/// A [`UdpClient`] driven by tokio. Refreshes and resubscriptions happen
/// while [`recv`](AsyncClient::recv) waits.
pub struct AsyncClient {
    inner: AsyncFd<UdpClient>,
}

impl AsyncClient {
    /// Must be called inside a tokio runtime with I/O enabled.
    pub fn new(client: UdpClient) -> io::Result<AsyncClient> {
        // SAFETY: a UdpClient's socket is created once, never replaced and
        // closed only when the client drops, so its descriptor stays valid and
        // the same while the AsyncFd owns it. This type never hands out
        // `&mut UdpClient`, through which the client could be swapped out.
        #[allow(unsafe_code)]
        let inner = unsafe { AsyncFd::register(client) }.map_err(io::Error::from)?;
        Ok(AsyncClient { inner })
    }

    /// The client inside.
    pub fn get_ref(&self) -> &UdpClient {
        self.inner.get_ref()
    }

    /// See [`UdpClient::subscribe`].
    pub fn subscribe(&mut self, subject: &str) -> Result<(), ClientError> {
        self.inner.get_mut().subscribe(subject)
    }

    /// See [`UdpClient::unsubscribe`].
    pub fn unsubscribe(&mut self, subject: &str) -> Result<(), ClientError> {
        self.inner.get_mut().unsubscribe(subject)
    }

    /// See [`UdpClient::publish`].
    pub fn publish(&mut self, packet: &[u8]) -> Result<(), ClientError> {
        self.inner.get_mut().publish(packet)
    }

    /// The next published packet, as the bytes received.
    pub async fn recv(&mut self) -> io::Result<Vec<u8>> {
        loop {
            self.inner.get_mut().poll(Instant::now())?;
            if let Some(p) = self.inner.get_mut().recv()? {
                return Ok(p.as_str().as_bytes().to_vec());
            }
            let deadline = self.inner.get_ref().next_deadline();
            let sleep = async {
                match deadline {
                    Some(d) => tokio::time::sleep_until(d.into()).await,
                    None => std::future::pending().await,
                }
            };
            tokio::select! {
                guard = self.inner.readable() => {
                    // Readiness is rechecked by the `recv` above on the next turn.
                    guard?.clear_ready();
                }
                _ = sleep => {}
            }
        }
    }
}
