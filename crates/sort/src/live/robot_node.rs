//! One robot's controller as a sans-IO node: observations in on
//! `camera.N`, a command on `radio` and an intention on `debug` out.

use std::collections::{BTreeSet, VecDeque};
use std::ops::DerefMut;

use colony_client::ClientError;
use colony_node::{Node, Time};
use colony_proto::radio::{self, RadioCommand};
use colony_proto::swarm::{camera, debug, CachePoint, Intent, Intentions};
use colony_sim::Observation;
use colony_wire::{Packet, Priority, Subject};
use rand_chacha::rand_core::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{wire_id, LiveError};
use crate::Controller;

/// A robot's controller on the hub: it subscribes to its camera channel and
/// answers observations with one command on `radio` (priority 0, so an
/// operator's outranks it) and one intention on `debug`.
///
/// Only the newest observation is acted on: [`handle_packet`](Node::handle_packet)
/// keeps it, and the controller steps when the transport asks for what to send
/// ([`poll_transmit`](Node::poll_transmit)), so observations that queued up
/// behind it while the controller was busy are skipped as stale. `C` is the
/// controller, boxed or borrowed.
pub struct RobotNode<C> {
    robot: usize,
    id: u32,
    controller: C,
    rng: ChaCha8Rng,
    subs: BTreeSet<Subject>,
    newest: Option<Observation>,
    outbox: VecDeque<Vec<u8>>,
    /// What stopped the controller: a command or intention it could not write.
    error: Option<LiveError>,
}

impl<C> RobotNode<C>
where
    C: DerefMut,
    C::Target: Controller,
{
    /// Robot `robot`'s controller; its random numbers come from `seed` and
    /// the robot's id, as in every earlier run of the same robot.
    pub fn new(robot: usize, controller: C, seed: u64) -> Result<RobotNode<C>, LiveError> {
        let id = wire_id(robot)?;
        Ok(RobotNode {
            robot,
            id,
            controller,
            rng: robot_rng(seed, robot),
            subs: [Subject::new(&camera::camera_channel(id)).map_err(ClientError::from)?].into(),
            newest: None,
            outbox: VecDeque::new(),
            error: None,
        })
    }

    /// The controller.
    pub fn controller(&self) -> &C::Target {
        &self.controller
    }

    /// What stopped the controller, if it failed; taken once.
    pub fn take_error(&mut self) -> Option<LiveError> {
        self.error.take()
    }

    /// Whether the controller has failed and stopped answering.
    pub fn failed(&self) -> bool {
        self.error.is_some()
    }

    /// Steps the controller on `obs` and queues its command and intention.
    fn act(&mut self, obs: &Observation) -> Result<(), LiveError> {
        let id = self.id;
        let controller = &mut *self.controller;
        let cmd = controller.step(obs, &mut self.rng);
        let command = radio::encode(
            &[RadioCommand {
                robot: id,
                wheels: cmd,
            }],
            Priority(0),
        )?;
        let intentions = Intentions {
            intents: vec![Intent {
                robot: id,
                state: controller.state().to_owned(),
                target: controller.target(),
            }],
            caches: controller
                .cache_points()
                .into_iter()
                .map(|(kind, pos)| CachePoint {
                    robot: id,
                    kind,
                    pos,
                })
                .collect(),
        };
        let intention = debug::encode(&intentions)?;
        self.outbox.extend([command, intention]);
        Ok(())
    }
}

/// Robot `robot`'s controller's random numbers, from the swarm's `seed` and the robot's id:
/// the same wherever the controller runs.
pub(crate) fn robot_rng(seed: u64, robot: usize) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed ^ (robot as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

impl<C> Node for RobotNode<C>
where
    C: DerefMut,
    C::Target: Controller,
{
    fn subscriptions(&self) -> &BTreeSet<Subject> {
        &self.subs
    }

    fn handle_packet(&mut self, _: Time, packet: &Packet<'_>) {
        match camera::decode(packet) {
            Ok(view) => self.newest = Some(view.observation),
            Err(e) => tracing::debug!(robot = self.robot, error = %e, "ignored a bad observation"),
        }
    }

    fn handle_timeout(&mut self, _: Time) {}

    fn poll_timeout(&self) -> Option<Time> {
        None
    }

    fn poll_transmit(&mut self) -> Option<Vec<u8>> {
        if self.outbox.is_empty() && self.error.is_none() {
            if let Some(obs) = self.newest.take() {
                if let Err(e) = self.act(&obs) {
                    self.error = Some(e);
                }
            }
        }
        self.outbox.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{build, Method, SortParams};

    fn controller() -> Box<dyn Controller> {
        build(Method::ProbSeek, &SortParams::default(), 2, 187.0)
    }

    fn view(robot: u32, step: u64) -> Vec<u8> {
        camera::encode(robot, step, &Observation::default()).unwrap()
    }

    #[test]
    fn it_subscribes_to_its_own_camera_only() {
        let node = RobotNode::new(3, controller(), 1).unwrap();
        let want: BTreeSet<Subject> = [Subject::new("camera.3").unwrap()].into();
        assert_eq!(node.subscriptions(), &want);
    }

    #[test]
    fn a_batch_of_observations_gives_one_command_and_one_intention() {
        let mut node = RobotNode::new(1, controller(), 1).unwrap();
        assert_eq!(node.poll_transmit(), None, "nothing seen, nothing said");
        for step in 1..=3 {
            node.handle_packet(Time::ZERO, &Packet::parse(&view(1, step)).unwrap());
        }
        let out: Vec<Vec<u8>> = std::iter::from_fn(|| node.poll_transmit()).collect();
        assert_eq!(out.len(), 2, "one command and one intention for the batch");
        let cmds = radio::decode(&Packet::parse(&out[0]).unwrap()).unwrap();
        assert_eq!(cmds.len(), 1);
        assert_eq!(cmds[0].robot, 1);
        assert_eq!(Packet::parse(&out[0]).unwrap().priority(), Priority(0));
        let intentions = debug::decode(&Packet::parse(&out[1]).unwrap()).unwrap();
        assert_eq!(intentions.intents[0].state, node.controller().state());
        assert_eq!(node.poll_transmit(), None);
    }

    #[test]
    fn a_borrowed_controller_steps_as_the_same_one_boxed() {
        let obs = view(0, 1);
        let mut boxed = RobotNode::new(0, controller(), 9).unwrap();
        let mut inner = controller();
        let mut borrowed = RobotNode::new(0, inner.as_mut(), 9).unwrap();
        boxed.handle_packet(Time::ZERO, &Packet::parse(&obs).unwrap());
        borrowed.handle_packet(Time::ZERO, &Packet::parse(&obs).unwrap());
        assert_eq!(boxed.poll_transmit(), borrowed.poll_transmit());
    }

    #[test]
    fn a_packet_that_is_not_an_observation_is_ignored() {
        let mut node = RobotNode::new(0, controller(), 1).unwrap();
        node.handle_packet(
            Time::ZERO,
            &Packet::parse(b"@ <camera.0> 0\nnonsense\n").unwrap(),
        );
        assert_eq!(node.poll_transmit(), None);
    }
}
