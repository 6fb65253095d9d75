//! The world's bodies for the page as one binary WebSocket message: every robot and puck of
//! the newest whole frame in typed arrays, which the page draws without a parse per body.
//! JSON of 10,000 robots and 100,000 pucks is some 5 MB to write and parse for each frame;
//! this is 1.5 MB, copied straight into `Float32Array`s.
//!
//! Little-endian, every array starting at a multiple of 4 bytes:
//!
//! | bytes | what |
//! |---|---|
//! | 4 | `CWB1` (colony world bodies, version 1) |
//! | 4 | `u32` robots `N` |
//! | 4 | `u32` pucks `M` |
//! | 4 | `u32` frame number (counts whole frames, wrapping) |
//! | 8 | `f64` the world's step |
//! | 12 `N` | `f32` x, y, theta of each robot (cm, rad) |
//! | 4 `N` | `u32` each robot's id |
//! | 4 `N` | `u32` the id of the puck each robot carries ([`NONE`]: none) |
//! | 8 `M` | `f32` x, y of each puck (cm) |
//! | 4 `M` | `u32` each puck's id |
//! | `M` | `u8` each puck's kind |
//!
//! Robots and pucks come sorted by id, as the frame holds them.

use colony_proto::swarm::VisionFrame;

/// The message's first four bytes.
pub const MAGIC: &[u8; 4] = b"CWB1";
/// Bytes before the arrays.
pub const HEADER: usize = 24;
/// A robot that carries nothing (a puck with this id is shown as not carried).
pub const NONE: u32 = u32::MAX;

/// `frame` as the page's binary message; `number` tells frames apart.
pub fn encode(frame: &VisionFrame, number: u64) -> Vec<u8> {
    let (n, m) = (frame.robots.len(), frame.pucks.len());
    let mut out = Vec::with_capacity(HEADER + 20 * n + 13 * m);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(n as u32).to_le_bytes());
    out.extend_from_slice(&(m as u32).to_le_bytes());
    out.extend_from_slice(&(number as u32).to_le_bytes());
    out.extend_from_slice(&(frame.step as f64).to_le_bytes());
    let f32s = |out: &mut Vec<u8>, v: f64| out.extend_from_slice(&(v as f32).to_le_bytes());
    for r in &frame.robots {
        f32s(&mut out, r.pose.x);
        f32s(&mut out, r.pose.y);
        f32s(&mut out, r.pose.theta);
    }
    for r in &frame.robots {
        out.extend_from_slice(&r.id.to_le_bytes());
    }
    for r in &frame.robots {
        out.extend_from_slice(&r.carrying.unwrap_or(NONE).to_le_bytes());
    }
    for p in &frame.pucks {
        f32s(&mut out, p.pos.x);
        f32s(&mut out, p.pos.y);
    }
    for p in &frame.pucks {
        out.extend_from_slice(&p.id.to_le_bytes());
    }
    out.extend(frame.pucks.iter().map(|p| p.kind.0));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use colony_proto::swarm::{PuckKind, VisionPuck, VisionRobot};
    use colony_proto::{Pose, Vec2};

    fn u32_at(b: &[u8], at: usize) -> u32 {
        u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }

    fn f32_at(b: &[u8], at: usize) -> f32 {
        f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }

    #[test]
    fn every_body_is_in_its_array_where_the_page_reads_it() {
        let frame = VisionFrame {
            step: 1234,
            robots: (0..3)
                .map(|id| VisionRobot {
                    id: id * 10,
                    pose: Pose {
                        x: id as f64,
                        y: -2.5,
                        theta: 0.5,
                    },
                    carrying: (id == 1).then_some(7),
                })
                .collect(),
            pucks: (0..5)
                .map(|id| VisionPuck {
                    id,
                    kind: PuckKind(id as u8 % 2),
                    pos: Vec2::new(4000.25, id as f64),
                })
                .collect(),
            ..VisionFrame::default()
        };
        let b = encode(&frame, 9);
        let (n, m) = (3, 5);
        assert_eq!(b.len(), HEADER + 20 * n + 13 * m);
        assert_eq!(&b[..4], MAGIC);
        assert_eq!((u32_at(&b, 4), u32_at(&b, 8), u32_at(&b, 12)), (3, 5, 9));
        assert_eq!(f64::from_le_bytes(b[16..24].try_into().unwrap()), 1234.0);
        let poses = HEADER;
        let ids = poses + 12 * n;
        let carrying = ids + 4 * n;
        let puck_pos = carrying + 4 * n;
        let puck_ids = puck_pos + 8 * m;
        let kinds = puck_ids + 4 * m;
        assert!([poses, ids, carrying, puck_pos, puck_ids, kinds]
            .iter()
            .all(|o| o % 4 == 0));
        assert_eq!(f32_at(&b, poses + 12), 1.0, "robot 1's x");
        assert_eq!(f32_at(&b, poses + 12 + 8), 0.5, "robot 1's theta");
        assert_eq!(u32_at(&b, ids + 8), 20);
        assert_eq!((u32_at(&b, carrying), u32_at(&b, carrying + 4)), (NONE, 7));
        assert_eq!(f32_at(&b, puck_pos + 8 * 4), 4000.25);
        assert_eq!(f32_at(&b, puck_pos + 8 * 4 + 4), 4.0);
        assert_eq!(u32_at(&b, puck_ids + 12), 3);
        assert_eq!(&b[kinds..], [0, 1, 0, 1, 0]);
    }
}
