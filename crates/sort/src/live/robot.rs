//! A robot's side of live mode: its controller as a hub client of its own.
//! The controller is a [`RobotNode`]; this runs it over a real hub.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use colony_client::UdpClient;
use colony_node::Link;

use super::{go_on, LiveError, RobotNode};
use crate::Controller;

/// Runs one robot's controller until `stop`: each camera observation from
/// the world becomes one command on `radio` and one intention on `debug`.
/// Only the newest observation is acted on; older ones waiting behind it are
/// stale by the time they are read.
pub fn run(
    robot: usize,
    controller: &mut dyn Controller,
    client: &mut UdpClient,
    seed: u64,
    stop: &AtomicBool,
) -> Result<(), LiveError> {
    let mut node = RobotNode::new(robot, controller, seed)?;
    let mut link = Link::new(client, Instant::now());
    colony_node::run(&mut node, &mut link, stop, |node, _| go_on(!node.failed()))?;
    node.take_error().map_or(Ok(()), Err)
}
