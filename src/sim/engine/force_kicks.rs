//! The force on the intruder as paper I applies it: a train of momentum kicks
//! F dt along +x, one every dt of real time (the paper: dt = 1 / (10^4 x the
//! collision rate)). Between kicks the intruder moves like any disk, straight
//! in the friction clock, so the pair scan and the wall times serve as they
//! are. Kick k comes at t0 + (k - 1/2) dt, the middle of its interval: the
//! impulse of F over [t0 + (k-1) dt, t0 + k dt]. The train is deterministic
//! (no random numbers): the bath's draws are those of the exact mode.

use super::Engine;
use super::parts::{NO_INTRUDER, Train};

impl Engine {
    /// Push the intruder with force `force` along +x as a train of kicks
    /// `force dt`, one every `dt` of real time from now on (the intruder then
    /// moves straight between kicks; [`Self::set_force`] is the exact mode).
    pub fn set_force_kicks(&mut self, force: f64, dt: f64) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.state.pulling.intruder != NO_INTRUDER,
            "no intruder to push"
        );
        anyhow::ensure!(
            force.is_finite() && force >= 0.0,
            "intruder force {force} is invalid: F must be finite and >= 0"
        );
        anyhow::ensure!(
            dt.is_finite() && dt > 0.0,
            "force kick interval {dt} is invalid: must be positive"
        );
        self.state.pulling.force = force;
        self.state.train = if force > 0.0 {
            Train {
                dt,
                t0: self.state.clock.t(self.state.now),
                k: 0,
                next: 0.0,
            }
        } else {
            Train::OFF
        };
        self.state.train.next = self.state.train.reading(&self.state.clock);
        self.state.next_kick = self.state.drive.next_drive.min(self.state.train.next);
        Ok(())
    }

    /// Force kicks given so far.
    pub fn force_kicks(&self) -> u64 {
        self.state.train.k
    }

    /// The next force kick (now): the intruder gets F dt along x; the kinetic
    /// energy it gains is the work of F (the ledger closes with it).
    pub(super) fn force_kick(&mut self) {
        let i = self.state.pulling.intruder;
        self.advance(i);
        let lam = self.lambda();
        let before = self.kinetic_energy_of(i);
        let m = self.mass(i) * lam;
        let d = &mut self.state.d[i];
        d.vx += self.state.pulling.force * self.state.train.dt / m;
        d.count = d.count.wrapping_add(1);
        let du = self.kinetic_energy_of(i) - before;
        if self.state.clock.gamma > 0.0 {
            self.account_friction();
            self.state.ke_u += du;
        }
        self.state.stats.work += du * (lam * lam);
        self.state.train.k += 1;
        self.state.train.next = self.state.train.reading(&self.state.clock);
        self.state.next_kick = self.state.drive.next_drive.min(self.state.train.next);
        self.predict(i);
    }
}
