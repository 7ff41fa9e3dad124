//! Stage 1: the bodies of the step in slot order, the loads on them, and
//! waking what touches awake bodies.

use std::collections::BTreeSet;

use glam::DVec3;

use super::StepInputs;
use crate::arena::Arena;
use crate::handle::BodyHandle;
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::joint::Joint;

/// Force (N) and torque (N·m) on each body from the force generators and
/// the extra loads (attachments), from the state at the start of the step.
pub(crate) fn external_loads(
    bodies: &Arena<RigidBody>,
    inputs: &StepInputs<'_>,
) -> Vec<(DVec3, DVec3)> {
    bodies
        .iter()
        .map(|(index, generation, b)| {
            let (f, t) = inputs.field.force_and_torque(b);
            let (ef, et) = inputs
                .extra
                .get(&BodyHandle { index, generation })
                .copied()
                .unwrap_or_default();
            (f + ef, t + et)
        })
        .collect()
}

/// What links bodies into islands: joints and touching contacts.
#[derive(Debug)]
pub(crate) struct Links<'a> {
    /// Pairs joined by a joint, smaller handle first.
    pub(crate) joined: BTreeSet<(BodyHandle, BodyHandle)>,
    /// Pairs touching at the end of the last step.
    touching: &'a BTreeSet<(BodyHandle, BodyHandle)>,
}

impl<'a> Links<'a> {
    pub(crate) fn new(
        joints: &Arena<Joint>,
        touching: &'a BTreeSet<(BodyHandle, BodyHandle)>,
    ) -> Self {
        let joined = joints
            .iter()
            .map(|(_, _, j)| (j.desc.a.min(j.desc.b), j.desc.a.max(j.desc.b)))
            .collect();
        Self { joined, touching }
    }

    /// Whether a joint joins `a` and `b`.
    #[inline]
    pub(crate) fn joined(&self, a: BodyHandle, b: BodyHandle) -> bool {
        !self.joined.is_empty() && self.joined.contains(&(a.min(b), a.max(b)))
    }

    /// Every link: touching pairs, then joints (a pair may come twice).
    pub(crate) fn all(&self) -> impl Iterator<Item = (BodyHandle, BodyHandle)> + Clone + '_ {
        self.touching.iter().chain(&self.joined).copied()
    }

    /// Sleeping bodies linked to awake ones wake up (through whole stacks
    /// and along joints). Nothing to do when nothing sleeps.
    pub(crate) fn wake(&self, bodies: &mut Arena<RigidBody>) {
        // Only an awake dynamic body can wake a sleeping one.
        let (mut sleeping, mut awake) = (false, false);
        for (_, _, b) in bodies.iter() {
            sleeping |= b.sleeping;
            awake |= b.kind == BodyKind::Dynamic && !b.sleeping && !b.quarantined;
            if sleeping && awake {
                break;
            }
        }
        if sleeping && awake {
            crate::rigid::island::wake_touched(bodies, self.all());
        }
    }
}
