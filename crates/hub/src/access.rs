//! Who the hub listens to: address ranges, and sources that can be no client.

use std::fmt;
use std::net::{IpAddr, SocketAddr};
use std::str::FromStr;

/// An address range, optionally one port: `10.0.0.0/8`, `192.168.1.7`,
/// `127.0.0.1:7500`, `::1`, `[::1]:7500`, `fd00::/8`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cidr {
    net: IpAddr,
    prefix: u8,
    port: Option<u16>,
}

/// Why a range could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{text}` is no address range (write ADDR, ADDR:PORT or ADDR/BITS, e.g. 10.0.0.0/8, 127.0.0.1:7500, fd00::/8)")]
pub struct CidrError {
    text: String,
}

impl FromStr for Cidr {
    type Err = CidrError;

    fn from_str(s: &str) -> Result<Cidr, CidrError> {
        let err = || CidrError { text: s.to_owned() };
        if let Ok(addr) = s.parse::<SocketAddr>() {
            return Ok(Cidr::host(canonical(addr.ip()), Some(addr.port())));
        }
        let (ip, bits) = match s.split_once('/') {
            Some((ip, bits)) => (ip, Some(bits)),
            None => (s, None),
        };
        let written: IpAddr = ip.parse().map_err(|_| err())?;
        let max = if written.is_ipv4() { 32 } else { 128 };
        let mut prefix = match bits {
            None => max,
            Some(b) => b.parse::<u8>().ok().filter(|&b| b <= max).ok_or_else(err)?,
        };
        // An IPv4-mapped range (`::ffff:10.0.0.0/104`) is the IPv4 range it
        // maps; its prefix counts the 96 bits of the mapping too.
        let ip = canonical(written);
        if ip.is_ipv4() && written.is_ipv6() {
            prefix = prefix.checked_sub(96).ok_or_else(err)?;
        }
        Ok(Cidr {
            net: mask(ip, prefix),
            prefix,
            port: None,
        })
    }
}

impl fmt::Display for Cidr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.port {
            Some(port) => SocketAddr::new(self.net, port).fmt(f),
            None => write!(f, "{}/{}", self.net, self.prefix),
        }
    }
}

impl Cidr {
    /// One address, and optionally one port of it.
    pub fn host(ip: IpAddr, port: Option<u16>) -> Cidr {
        let ip = canonical(ip);
        Cidr {
            net: ip,
            prefix: if ip.is_ipv4() { 32 } else { 128 },
            port,
        }
    }

    /// Whether `addr` lies in the range.
    pub fn contains(&self, addr: &SocketAddr) -> bool {
        if self.port.is_some_and(|p| p != addr.port()) {
            return false;
        }
        let ip = canonical(addr.ip());
        ip.is_ipv4() == self.net.is_ipv4() && mask(ip, self.prefix) == self.net
    }

    /// Whether the range is the loopback network or inside it.
    pub fn is_loopback(&self) -> bool {
        self.net.is_loopback() && self.prefix >= if self.net.is_ipv4() { 8 } else { 128 }
    }
}

/// An IPv4-mapped IPv6 address as the IPv4 address it is, so that a range
/// written for IPv4 covers it on a dual-stack socket.
fn canonical(ip: IpAddr) -> IpAddr {
    match ip {
        IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(ip, IpAddr::V4),
        v4 => v4,
    }
}

fn mask(ip: IpAddr, prefix: u8) -> IpAddr {
    match canonical(ip) {
        IpAddr::V4(v4) => {
            let bits = u32::from(v4);
            let m = u32::MAX
                .checked_shl(32u32.saturating_sub(u32::from(prefix)))
                .unwrap_or(0);
            IpAddr::V4((bits & m).into())
        }
        IpAddr::V6(v6) => {
            let bits = u128::from(v6);
            let m = u128::MAX
                .checked_shl(128u32.saturating_sub(u32::from(prefix)))
                .unwrap_or(0);
            IpAddr::V6((bits & m).into())
        }
    }
}

/// Whether `src` can be no client of a hub listening on `local`: port 0,
/// an unspecified, broadcast or multicast address, or the hub itself (its
/// own address; with the hub on every address, any address with its port).
/// The hub never subscribes, forwards to or answers such a source: one
/// forged packet from its own address would otherwise have it send to
/// itself for ever.
pub fn is_bad_source(src: &SocketAddr, local: Option<&SocketAddr>) -> bool {
    let ip = canonical(src.ip());
    if src.port() == 0 || ip.is_unspecified() || ip.is_multicast() {
        return true;
    }
    if let IpAddr::V4(v4) = ip {
        // A subnet's broadcast address cannot be told from a host's here; it
        // never proves return routability, so it gets no more than a cookie.
        if v4.is_broadcast() {
            return true;
        }
    }
    let Some(local) = local else { return false };
    if src.port() != local.port() {
        return false;
    }
    let own = canonical(local.ip());
    own.is_unspecified() || own == ip || own.is_loopback() && ip.is_loopback()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn addr(s: &str) -> SocketAddr {
        s.parse().unwrap()
    }

    #[test]
    fn ranges_read_as_written() {
        let c: Cidr = "10.1.0.0/16".parse().unwrap();
        assert!(c.contains(&addr("10.1.200.3:5000")));
        assert!(!c.contains(&addr("10.2.0.1:5000")));
        let one: Cidr = "127.0.0.1:7500".parse().unwrap();
        assert!(one.contains(&addr("127.0.0.1:7500")));
        assert!(!one.contains(&addr("127.0.0.1:7501")));
        let host: Cidr = "192.168.1.7".parse().unwrap();
        assert!(host.contains(&addr("192.168.1.7:1")));
        assert!(!host.contains(&addr("192.168.1.8:1")));
        let v6: Cidr = "fd00::/8".parse().unwrap();
        assert!(v6.contains(&addr("[fd12::1]:9")));
        assert!(!v6.contains(&addr("10.0.0.1:9")));
        let mapped: Cidr = "10.0.0.0/8".parse().unwrap();
        assert!(mapped.contains(&addr("[::ffff:10.0.0.1]:9")));
        assert!("0.0.0.0/0"
            .parse::<Cidr>()
            .unwrap()
            .contains(&addr("8.8.8.8:53")));
        for bad in [
            "",
            "10.0.0.0/33",
            "10.0.0/8",
            "host",
            "::1/129",
            "1.2.3.4/-1",
            "1.2.3.4:99999",
        ] {
            assert!(bad.parse::<Cidr>().is_err(), "{bad} was read");
        }
    }

    #[test]
    fn the_hub_itself_and_unreachable_sources_are_no_clients() {
        let local = addr("127.0.0.1:7400");
        for s in [
            "127.0.0.1:7400",
            "127.0.0.2:7400",
            "127.0.0.1:0",
            "0.0.0.0:5000",
            "224.0.0.1:5000",
            "255.255.255.255:5000",
        ] {
            assert!(is_bad_source(&addr(s), Some(&local)), "{s}");
        }
        for s in ["127.0.0.1:7401", "192.168.1.7:7400", "10.0.0.1:5000"] {
            assert!(!is_bad_source(&addr(s), Some(&local)), "{s}");
        }
        let any = addr("0.0.0.0:7400");
        assert!(is_bad_source(&addr("192.168.1.7:7400"), Some(&any)));
        assert!(!is_bad_source(&addr("192.168.1.7:7401"), Some(&any)));
    }

    proptest! {
        #[test]
        fn reading_a_range_never_panics(s in "\\PC{0,40}") {
            let _ = s.parse::<Cidr>();
        }

        #[test]
        fn an_ipv6_range_holds_only_its_own_network(a in any::<u128>(), bits in 0u8..=128, other in any::<u128>()) {
            let ip = IpAddr::V6(a.into());
            let c: Cidr = format!("{ip}/{bits}").parse().unwrap();
            prop_assert!(c.contains(&SocketAddr::new(ip, 1)));
            let o = IpAddr::V6(other.into());
            let same = bits == 0 || (a ^ other) >> (128 - u32::from(bits)) == 0;
            let mapped = |x: u128| std::net::Ipv6Addr::from(x).to_ipv4_mapped().is_some();
            if !mapped(a) && !mapped(other) {
                prop_assert_eq!(c.contains(&SocketAddr::new(o, 1)), same);
            }
        }

        #[test]
        fn a_range_holds_its_own_network(a in any::<u32>(), bits in 0u8..=32, port in 1u16..) {
            let ip = IpAddr::V4(a.into());
            let c: Cidr = format!("{ip}/{bits}").parse().unwrap();
            prop_assert!(c.contains(&SocketAddr::new(ip, port)));
            prop_assert_eq!(c.to_string().parse::<Cidr>().unwrap(), c);
        }
    }
}
