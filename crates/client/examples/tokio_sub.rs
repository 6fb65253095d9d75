//! Subscribing from a tokio program with the `tokio` feature.
//!
//! `cargo run -p colony-client --features tokio --example tokio_sub`

use colony_client::{AsyncClient, UdpClient};

#[tokio::main(flavor = "current_thread")]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let hub = std::env::var("COLONY_HUB").unwrap_or_else(|_| "127.0.0.1:7400".into());
    let mut client = UdpClient::connect(hub.as_str())?;
    client.subscribe("vision_out")?;
    let mut client = AsyncClient::new(client)?;
    loop {
        let datagram = client.recv().await?;
        print!("{}", String::from_utf8_lossy(&datagram));
    }
}
