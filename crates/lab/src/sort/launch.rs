//! Launching a live swarm: the world over a hub and every robot's
//! controller as a hub client of its own, in threads of this process, in
//! child processes, or elsewhere (`colony sort live` is this and a flag
//! parser; `colony sort robot` is [`run_controller`]).

use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use colony_client::{ConnectError, UdpClient};
use colony_sim::{SceneConfig, SimError, World};
use colony_sort::live::world::{self, WorldOptions};
use colony_sort::live::{robot, LiveError};
use colony_sort::methods::{build, Method};
use colony_sort::params::SortParams;
use colony_sort::Controller;

/// Why a swarm could not be launched or run.
#[derive(Debug, thiserror::Error)]
pub enum LaunchError {
    /// The scene cannot be built.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A hub client could not be made.
    #[error(transparent)]
    Connect(#[from] ConnectError),
    /// A robot's controller could not be started.
    #[error("cannot start the controller of robot {robot}")]
    Spawn {
        /// The robot.
        robot: usize,
        /// Why.
        source: std::io::Error,
    },
    /// There is no such robot in the scene.
    #[error("--id {id} is out of range: the scene has {count} robots (0 to {})", count.saturating_sub(1))]
    NoSuchRobot {
        /// The id asked for.
        id: usize,
        /// Robots in the scene.
        count: usize,
    },
    /// The world or a controller failed.
    #[error(transparent)]
    Live(#[from] LiveError),
    /// A controller's thread panicked (which robot's).
    #[error("the controller of robot {0} panicked")]
    ControllerPanicked(usize),
}

/// What every part of a live swarm must agree on.
#[derive(Debug, Clone)]
pub struct SwarmSpec {
    /// The hub's address.
    pub hub: String,
    /// The scene.
    pub scene: SceneConfig,
    /// The sorting parameters.
    pub params: SortParams,
    /// The controllers' method.
    pub method: Method,
    /// Seeds the world and, mixed with each robot's id, its controller.
    pub seed: u64,
}

/// The most robots whose controllers [`Controllers::Threads`] gives a thread (and a hub
/// client) each; a larger swarm's controllers run [`Controllers::InWorld`].
pub const MAX_CONTROLLER_THREADS: usize = 1024;

/// Where the robots' controllers run.
pub enum Controllers {
    /// One thread of this process each, up to [`MAX_CONTROLLER_THREADS`] robots; a larger
    /// swarm's run [`InWorld`](Controllers::InWorld). (At 10,000 robots, a thread and a hub
    /// client each means 10,000 threads on a few cores and, every step, 10,000 observations
    /// through the hub and 20,000 commands and intentions back: the hub, not the world, would
    /// set the pace, and the world view would starve.)
    Threads,
    /// In the world's own step, on its thread: each robot's observation goes straight to its
    /// controller and its command straight to the hold rule (at priority 0, so an operator's
    /// command on `radio` still outranks it); nothing goes on `camera.N` or `debug` for them.
    /// What a swarm of thousands needs for the world to publish its whole state every step.
    InWorld,
    /// One child process each, started with the command this makes for a
    /// robot id (for `colony`, `colony sort robot --id N ...`). The children
    /// are killed when the swarm ends.
    Processes(Box<dyn Fn(usize) -> Command>),
    /// None: they are started elsewhere.
    External,
}

fn connect(hub: &str) -> Result<UdpClient, LaunchError> {
    Ok(UdpClient::connect_to(hub)?)
}

/// Child processes that are killed when this value drops, however we leave.
struct Children(Vec<Child>);

impl Drop for Children {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// A swarm whose controllers are running, and whose world is ready to run.
pub struct Swarm {
    world: World,
    client: UdpClient,
    spec: SwarmSpec,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<Result<(), LiveError>>>,
    children: Children,
    /// Controllers the world steps itself ([`Controllers::InWorld`]).
    inline: Vec<Box<dyn Controller>>,
}

impl Swarm {
    /// Builds the world and starts every robot's controller as `controllers`
    /// says; they run until `stop` is set.
    pub fn launch(
        spec: &SwarmSpec,
        controllers: Controllers,
        stop: &Arc<AtomicBool>,
    ) -> Result<Swarm, LaunchError> {
        let world = World::new(&spec.scene, spec.seed)?;
        let n = world.robot_count();
        let mut threads = Vec::new();
        let mut children = Children(Vec::new());
        let mut inline = Vec::new();
        let controllers = match controllers {
            Controllers::Threads if n > MAX_CONTROLLER_THREADS => {
                tracing::info!(
                    robots = n,
                    "{n} robots: their controllers run in the world's step, not a thread each \
                     (at most {MAX_CONTROLLER_THREADS})"
                );
                Controllers::InWorld
            }
            c => c,
        };
        let started = (|| {
            match &controllers {
                Controllers::InWorld => inline = (0..n).map(|_| controller(spec)).collect(),
                Controllers::Threads => {
                    for id in 0..n {
                        let mut controller = controller(spec);
                        let mut client = connect(&spec.hub)?;
                        let (stop, seed) = (stop.clone(), spec.seed);
                        threads.push(std::thread::spawn(move || {
                            robot::run(id, controller.as_mut(), &mut client, seed, &stop)
                        }));
                    }
                }
                Controllers::Processes(command) => {
                    for id in 0..n {
                        let child = command(id)
                            .stdin(Stdio::null())
                            .spawn()
                            .map_err(|source| LaunchError::Spawn { robot: id, source })?;
                        children.0.push(child);
                    }
                }
                Controllers::External => {}
            }
            connect(&spec.hub)
        })();
        match started {
            Ok(client) => Ok(Swarm {
                world,
                client,
                spec: spec.clone(),
                stop: stop.clone(),
                threads,
                children,
                inline,
            }),
            Err(e) => {
                // Whatever started must not outlive the launch.
                stop.store(true, Ordering::Relaxed);
                Err(e)
            }
        }
    }

    /// How many robots the world holds.
    pub fn robot_count(&self) -> usize {
        self.world.robot_count()
    }

    /// Runs the world at `speed` times real time until `stop` is set or
    /// `max_steps` pass, calling `each_step` after every step; then stops
    /// the controllers and waits for them (child processes are killed).
    pub fn run(
        mut self,
        speed: f64,
        max_steps: Option<u64>,
        each_step: impl FnMut(&World),
    ) -> Result<(), LaunchError> {
        let scene = &self.spec.scene;
        let options = WorldOptions {
            step_seconds: scene.physics.dt * scene.physics.substeps as f64,
            speed,
            command_timeout_steps: 10,
            max_steps,
            metrics_every: 10,
            cluster_threshold: self.spec.params.perception.cluster_threshold_cm,
        };
        let result = world::run_with_controllers(
            &mut self.world,
            &mut self.client,
            &options,
            std::mem::take(&mut self.inline),
            self.spec.seed,
            &self.stop,
            each_step,
        );
        self.stop.store(true, Ordering::Relaxed);
        // Every controller is waited for; the world's failure, else the first controller's,
        // is the swarm's.
        let mut controllers = Ok(());
        for (robot, t) in self.threads.drain(..).enumerate() {
            let ended = match t.join() {
                Ok(r) => r.map_err(LaunchError::from),
                Err(_) => Err(LaunchError::ControllerPanicked(robot)),
            };
            controllers = controllers.and(ended);
        }
        drop(self.children);
        result?;
        controllers
    }
}

fn controller(spec: &SwarmSpec) -> Box<dyn Controller> {
    build(
        spec.method,
        &spec.params,
        spec.scene.pucks.kinds,
        spec.scene.arena.width,
    )
}

/// Runs robot `id`'s controller over the hub until `stop` is set.
pub fn run_controller(spec: &SwarmSpec, id: usize, stop: &AtomicBool) -> Result<(), LaunchError> {
    if id >= spec.scene.robots.count {
        return Err(LaunchError::NoSuchRobot {
            id,
            count: spec.scene.robots.count,
        });
    }
    let mut controller = controller(spec);
    let mut client = connect(&spec.hub)?;
    robot::run(id, controller.as_mut(), &mut client, spec.seed, stop)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> SwarmSpec {
        SwarmSpec {
            hub: "127.0.0.1:9".into(),
            scene: SceneConfig::default(),
            params: SortParams::default(),
            method: Method::CacheCons,
            seed: 1,
        }
    }

    #[test]
    fn a_robot_outside_the_scene_is_refused_by_name() {
        let e = run_controller(&spec(), 99, &AtomicBool::new(true)).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--id 99 is out of range: the scene has 4 robots (0 to 3)"
        );
    }

    #[test]
    fn a_swarm_too_big_for_a_thread_each_runs_its_controllers_in_the_world() {
        let stop = Arc::new(AtomicBool::new(false));
        let spec = SwarmSpec {
            scene: SceneConfig::scaled(MAX_CONTROLLER_THREADS + 1),
            ..spec()
        };
        let swarm = Swarm::launch(&spec, Controllers::Threads, &stop).unwrap();
        assert!(swarm.threads.is_empty(), "no thread per robot");
        assert_eq!(swarm.inline.len(), MAX_CONTROLLER_THREADS + 1);
    }

    #[test]
    fn external_controllers_start_nothing() {
        let stop = Arc::new(AtomicBool::new(false));
        let swarm = Swarm::launch(&spec(), Controllers::External, &stop).unwrap();
        assert_eq!(swarm.robot_count(), 4);
        assert!(swarm.threads.is_empty() && swarm.children.0.is_empty());
    }
}
