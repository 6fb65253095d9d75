//! Loopback ports for a test's servers.
//!
//! A port found free may be taken by another process before the test binds
//! it; on loopback, between two calls, that is rare enough for tests.

use std::net::{TcpListener, UdpSocket};

/// A TCP port free on loopback just now.
pub fn free_tcp_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A UDP port free on loopback just now.
pub fn free_udp_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Zenoh's locator for TCP `port` on loopback.
pub fn tcp_endpoint(port: u16) -> String {
    format!("tcp/127.0.0.1:{port}")
}
