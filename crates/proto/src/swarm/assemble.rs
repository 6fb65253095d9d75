//! Putting the parts of a `vision` frame back together.
//!
//! The world splits a big swarm's frame into parts ([`super::vision::encode`]); the hub may lose
//! or reorder any of them. A reader keeps one frame in the making: a part of another step (a
//! newer one, or an older one after the world restarted) starts it afresh, dropping an unfinished
//! one, and the frame is handed out only once every part is in, so a viewer never shows half a
//! world. Each frame dropped so, with some of its parts in and not all, is counted
//! ([`VisionAssembler::missing`]): a viewer shows that count, so a loss is never silent. (A frame
//! none of whose parts arrived leaves no trace here; the hub's drop counts show those.)

use super::vision::{VisionFrame, VisionPart};

/// Collects the parts of one step's vision into one frame.
///
/// ```
/// use colony_proto::swarm::{VisionAssembler, VisionFrame, VisionPart};
/// let part = |part, step| VisionPart { part, parts: 2, frame: VisionFrame { step, ..VisionFrame::default() } };
/// let mut a = VisionAssembler::default();
/// assert_eq!(a.offer(part(1, 9)), None);
/// assert_eq!(a.offer(part(0, 9)).map(|f| f.step), Some(9));
/// ```
#[derive(Debug, Default)]
pub struct VisionAssembler {
    making: Option<Making>,
    missing: u64,
    /// The step of the frame last handed out: a late copy of one of its parts is no new frame.
    done: Option<u64>,
}

#[derive(Debug)]
struct Making {
    seen: Vec<bool>,
    frame: VisionFrame,
}

impl VisionAssembler {
    /// An assembler with no frame in the making.
    pub fn new() -> VisionAssembler {
        VisionAssembler::default()
    }

    /// Frames dropped unfinished so far: a part of another frame came while some of this one's
    /// parts were still missing.
    pub fn missing(&self) -> u64 {
        self.missing
    }

    /// Takes one part; returns the whole frame once every part of its step is in, with its
    /// robots and pucks sorted by id. A part seen before is ignored; a part out of its own range
    /// (which [`super::vision::decode`] never returns) is ignored too. A part of another frame
    /// drops the unfinished one, counted in [`missing`](Self::missing).
    pub fn offer(&mut self, part: VisionPart) -> Option<VisionFrame> {
        let VisionPart { part, parts, frame } = part;
        if part >= parts || (self.making.is_none() && self.done == Some(frame.step)) {
            return None;
        }
        let fresh = match &self.making {
            Some(m) => m.frame.step != frame.step || m.seen.len() != parts as usize,
            None => true,
        };
        if fresh {
            if self.making.is_some() {
                self.missing += 1;
            }
            self.making = Some(Making {
                seen: vec![false; parts as usize],
                frame: VisionFrame {
                    step: frame.step,
                    ..VisionFrame::default()
                },
            });
        }
        let m = self.making.as_mut()?;
        if std::mem::replace(&mut m.seen[part as usize], true) {
            return None;
        }
        m.frame.arena = frame.arena.or(m.frame.arena);
        m.frame.sizes = frame.sizes.or(m.frame.sizes);
        m.frame.robots.extend(frame.robots);
        m.frame.pucks.extend(frame.pucks);
        m.frame.boxes.extend(frame.boxes);
        m.frame.goal = frame.goal.or(m.frame.goal);
        if !m.seen.iter().all(|s| *s) {
            return None;
        }
        let mut done = self.making.take()?.frame;
        self.done = Some(done.step);
        done.robots.sort_by_key(|r| r.id);
        done.pucks.sort_by_key(|p| p.id);
        Some(done)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::swarm::vision::{self, VisionPuck, VisionRobot};
    use crate::swarm::PuckKind;
    use crate::{Pose, Vec2};
    use colony_wire::Packet;

    /// `n` robots, all at the same pose.
    fn robots(n: u32) -> Vec<VisionRobot> {
        (0..n)
            .map(|id| VisionRobot {
                id,
                pose: Pose {
                    x: 1.0,
                    y: 2.0,
                    theta: 0.5,
                },
                carrying: None,
            })
            .collect()
    }

    fn part(step: u64, part: u32, parts: u32, robot: Option<(u32, f64)>) -> VisionPart {
        VisionPart {
            part,
            parts,
            frame: VisionFrame {
                step,
                robots: robot
                    .map(|(id, x)| VisionRobot {
                        id,
                        pose: Pose {
                            x,
                            y: 0.0,
                            theta: 0.0,
                        },
                        carrying: None,
                    })
                    .into_iter()
                    .collect(),
                ..VisionFrame::default()
            },
        }
    }

    #[test]
    fn a_split_frame_is_handed_out_only_once_every_part_is_in() {
        let mut a = VisionAssembler::new();
        assert_eq!(a.offer(part(9, 1, 2, Some((1, 1.0)))), None);
        assert_eq!(
            a.offer(part(9, 1, 2, Some((1, 1.0)))),
            None,
            "a duplicate completes nothing"
        );
        let f = a.offer(part(9, 0, 2, Some((0, 0.0)))).unwrap();
        assert_eq!(
            f.robots.iter().map(|r| r.id).collect::<Vec<_>>(),
            [0, 1],
            "sorted by id"
        );
        // A lost part: the next step's parts replace the unfinished frame.
        assert_eq!(a.offer(part(10, 0, 2, Some((0, 5.0)))), None);
        assert_eq!(a.offer(part(11, 1, 2, None)), None);
        let f = a.offer(part(11, 0, 2, Some((0, 6.0)))).unwrap();
        assert_eq!((f.step, f.robots.len(), f.robots[0].pose.x), (11, 1, 6.0));
        assert_eq!(a.offer(part(12, 3, 2, None)), None, "out of range");
        assert_eq!(a.missing(), 1, "step 10 was dropped half in");
    }

    #[test]
    fn a_frame_with_a_lost_part_is_counted_missing_and_never_handed_out() {
        let frame = VisionFrame {
            step: 5,
            robots: robots(6000),
            ..VisionFrame::default()
        };
        let mut a = VisionAssembler::new();
        for step in [5, 6, 7] {
            let parts = vision::encode(&VisionFrame {
                step,
                ..frame.clone()
            })
            .unwrap();
            assert!(parts.len() >= 3, "{}", parts.len());
            for (i, bytes) in parts.iter().enumerate() {
                // Step 6 loses its middle part.
                if step == 6 && i == 1 {
                    continue;
                }
                let got = a.offer(vision::decode(&Packet::parse(bytes).unwrap()).unwrap());
                let last = i + 1 == parts.len();
                assert_eq!(got.is_some(), last && step != 6, "step {step} part {i}");
                if let Some(f) = got {
                    assert_eq!((f.step, f.robots.len()), (step, 6000));
                }
            }
        }
        assert_eq!(a.missing(), 1, "step 6 only");
        // A late copy of a part of the frame just handed out starts no frame to drop.
        let late = vision::encode(&VisionFrame {
            step: 7,
            ..frame.clone()
        })
        .unwrap();
        assert_eq!(
            a.offer(vision::decode(&Packet::parse(&late[0]).unwrap()).unwrap()),
            None
        );
        let next = vision::encode(&VisionFrame { step: 8, ..frame }).unwrap();
        for bytes in &next {
            a.offer(vision::decode(&Packet::parse(bytes).unwrap()).unwrap());
        }
        assert_eq!(a.missing(), 1);
    }

    #[test]
    fn an_encoded_frame_comes_back_whole_in_any_order() {
        let frame = VisionFrame {
            step: 3,
            arena: None,
            sizes: None,
            robots: robots(300),
            pucks: (0..3000)
                .map(|id| VisionPuck {
                    id,
                    kind: PuckKind(2),
                    pos: Vec2::new(-1.25, 3.5),
                })
                .collect(),
            // In the last part: the assembler keeps them from any part.
            boxes: vec![vision::VisionBox {
                id: 4,
                pose: Pose {
                    x: 1.0,
                    y: 2.0,
                    theta: 0.5,
                },
                length: 60.0,
                width: 8.0,
            }],
            goal: Some(Vec2::new(7.0, 8.0)),
        };
        let parts = vision::encode(&frame).unwrap();
        assert!(parts.len() > 1);
        let mut a = VisionAssembler::new();
        let mut whole = None;
        for bytes in parts.iter().rev() {
            let p = vision::decode(&Packet::parse(bytes).unwrap()).unwrap();
            whole = a.offer(p);
        }
        assert_eq!(whole, Some(frame));
    }
}
