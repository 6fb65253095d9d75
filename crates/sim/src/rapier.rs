//! The rapier2d state both worlds share: every set rapier's pipeline needs, one step
//! function, and the conversions and body moves the arena and the tile-map field have in
//! common.
//!
//! Lengths are centimetres throughout and rapier is told so
//! (`IntegrationParameters::length_unit = 100`, i.e. 100 units per metre), which scales its
//! internal tolerances. Masses are grams; gravity is zero (a top view).

use rapier2d::prelude::*;

use crate::types::{Pose as WorldPose, Vec2};

/// All of rapier's state for one world.
pub(crate) struct Rapier {
    pub bodies: RigidBodySet,
    pub colliders: ColliderSet,
    pub params: IntegrationParameters,
    pipeline: PhysicsPipeline,
    islands: IslandManager,
    broad_phase: BroadPhaseBvh,
    narrow_phase: NarrowPhase,
    impulse_joints: ImpulseJointSet,
    multibody_joints: MultibodyJointSet,
    soft_bodies: SoftBodySet,
    ccd: CCDSolver,
}

impl Rapier {
    /// An empty world stepped with `params`.
    pub fn new(params: IntegrationParameters) -> Rapier {
        Rapier {
            bodies: RigidBodySet::new(),
            colliders: ColliderSet::new(),
            params,
            pipeline: PhysicsPipeline::new(),
            islands: IslandManager::new(),
            broad_phase: BroadPhaseBvh::new(),
            narrow_phase: NarrowPhase::new(),
            impulse_joints: ImpulseJointSet::new(),
            multibody_joints: MultibodyJointSet::new(),
            soft_bodies: SoftBodySet::new(),
            ccd: CCDSolver::new(),
        }
    }

    /// Attaches `collider` to the body `parent`.
    pub fn attach(&mut self, collider: impl Into<Collider>, parent: RigidBodyHandle) {
        self.colliders
            .insert_with_parent(collider, parent, &mut self.bodies);
    }

    /// Sets a robot's velocity for the next physics step: `speed` cm/s along its heading
    /// (nothing sideways: tracks do not slide) and `turn` rad/s.
    pub fn drive(&mut self, handle: RigidBodyHandle, speed: f64, turn: f64) {
        if let Some(rb) = self.bodies.get_mut(handle) {
            let rot = *rb.rotation();
            let s = speed as f32;
            rb.set_linvel(Vector::new(rot.re * s, rot.im * s), true);
            rb.set_angvel(turn as f32, true);
        }
    }

    /// Stops a body dead (after a teleport or a respawn: a disturbance, not physics).
    pub fn halt(&mut self, handle: RigidBodyHandle) {
        if let Some(rb) = self.bodies.get_mut(handle) {
            rb.set_linvel(Vector::ZERO, true);
            rb.set_angvel(0.0, true);
        }
    }

    /// `n` physics steps of `params.dt`, `before(self, k)` setting up the `k`-th (a control
    /// step's substeps: its wheel commands).
    pub fn steps<F>(&mut self, n: u32, before: F)
    where
        F: FnMut(&mut Rapier, u32) + Send,
    {
        let run = move |rapier: &mut Rapier| {
            let mut before = before;
            for k in 0..n {
                before(rapier, k);
                rapier.step();
            }
        };
        #[cfg(feature = "parallel-physics")]
        self.in_lent_pool(run);
        #[cfg(not(feature = "parallel-physics"))]
        run(self);
    }

    /// Runs `run` in a thread pool lent to this world alone (see `crate::pools`).
    #[cfg(feature = "parallel-physics")]
    fn in_lent_pool(&mut self, run: impl FnOnce(&mut Rapier) + Send) {
        let pool = crate::pools::SHARED.lend().unwrap_or_else(|e| {
            // Stepping in the caller's rayon context instead could hang (see
            // `crate::pools`): better to stop and say why.
            panic!("the system refused threads for rapier's parallel physics: {e}")
        });
        if rayon::current_thread_index().is_none() {
            pool.install(|| run(self));
        } else {
            // A rayon worker waiting for another pool takes jobs from its own while it
            // waits: a sibling trial, nested inside this one, and the next inside that,
            // until every trial of a batch is alive at once, each deeper on the worker's
            // stack. A thread of our own waits instead, and the worker waits for it,
            // taking nothing.
            std::thread::scope(|scope| {
                let waiter = scope.spawn(|| pool.install(|| run(self)));
                if let Err(panic) = waiter.join() {
                    std::panic::resume_unwind(panic);
                }
            });
        }
    }

    /// Contact points in the pairs that touch (or are within rapier's prediction distance).
    pub fn contact_points(&self) -> usize {
        self.narrow_phase
            .contact_pairs()
            .filter(|p| p.has_any_active_contact())
            .map(|p| p.manifolds().iter().map(|m| m.points.len()).sum::<usize>())
            .sum()
    }

    /// Bodies asleep (rapier's islands at rest).
    pub fn sleeping_bodies(&self) -> usize {
        self.bodies.iter().filter(|(_, b)| b.is_sleeping()).count()
    }

    /// One physics step, on the calling thread and, with `parallel-physics`, its rayon pool.
    fn step(&mut self) {
        self.pipeline.step(
            Vector::ZERO,
            &self.params,
            &mut self.islands,
            &mut self.broad_phase,
            &mut self.narrow_phase,
            &mut self.bodies,
            &mut self.colliders,
            &mut self.impulse_joints,
            &mut self.multibody_joints,
            &mut self.soft_bodies,
            &mut self.ccd,
            &(),
            &(),
        );
    }
}

/// Interaction groups that meet when both sides agree.
pub(crate) fn groups(member: Group, filter: Group) -> InteractionGroups {
    InteractionGroups::new(member, filter, InteractionTestMode::And)
}

/// A point as rapier's vector.
pub(crate) fn vector(p: Vec2) -> Vector {
    Vector::new(p.x as f32, p.y as f32)
}

/// A world pose as rapier's, with portable trigonometry (see the crate's determinism notes).
pub(crate) fn rapier_pose(p: WorldPose) -> Pose {
    let (s, c) = libm::sincos(p.theta);
    Pose::from_parts(
        Vector::new(p.x as f32, p.y as f32),
        Rotation {
            re: c as f32,
            im: s as f32,
        },
    )
}
