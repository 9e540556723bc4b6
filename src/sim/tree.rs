//! The event calendar: a tournament tree over one event time per particle.
//!
//! Each particle owns exactly one pending event (its earliest predicted collision
//! or cell crossing), so the calendar never grows and never allocates after
//! construction. Leaf `i` holds particle `i`'s event time; every internal node
//! keeps the winner (earliest leaf) of its subtree and that winner's time, so the
//! root is the next event. An update climbs towards the root and stops as soon as
//! a node's winner and time are unchanged, which for late events is after a few
//! levels.

pub struct EventTree {
    /// Number of leaves (a power of two >= number of particles).
    leaves: usize,
    /// Winner (leaf index) of each node; leaves at `leaves..2 leaves`.
    win: Vec<u32>,
    /// Event time of each node's winner (infinity for padding leaves).
    time: Vec<f64>,
}

impl EventTree {
    /// A tree over `n` particles, all without events (time infinity).
    pub fn new(n: usize) -> Self {
        let leaves = n.next_power_of_two().max(2);
        let mut t = EventTree {
            leaves,
            win: vec![0; 2 * leaves],
            time: vec![f64::INFINITY; 2 * leaves],
        };
        for i in 0..leaves {
            t.win[leaves + i] = i as u32;
        }
        t.rebuild();
        t
    }

    /// Set a leaf's time without fixing the tree (call [`Self::rebuild`] after).
    #[inline]
    pub fn set_lazy(&mut self, i: usize, t: f64) {
        self.time[self.leaves + i] = t;
    }

    /// Recompute every internal node.
    pub fn rebuild(&mut self) {
        for k in (1..self.leaves).rev() {
            let w = self.better(2 * k);
            self.win[k] = self.win[w];
            self.time[k] = self.time[w];
        }
    }

    /// The child of `k`'s parent-to-be pair (`l`, `l + 1`) that wins; ties go to
    /// the left (lower index), so the order of events is reproducible.
    #[inline]
    fn better(&self, l: usize) -> usize {
        if self.time[l + 1] < self.time[l] {
            l + 1
        } else {
            l
        }
    }

    /// Particle with the earliest event, and its time.
    #[inline]
    pub fn min(&self) -> (usize, f64) {
        (self.win[1] as usize, self.time[1])
    }

    /// Event time of particle `i`.
    #[inline]
    pub fn time(&self, i: usize) -> f64 {
        self.time[self.leaves + i]
    }

    /// Give particle `i` the event time `t`.
    #[inline]
    pub fn update(&mut self, i: usize, t: f64) {
        let mut k = self.leaves + i;
        self.time[k] = t;
        k /= 2;
        while k >= 1 {
            let w = self.better(2 * k);
            let (nw, nt) = (self.win[w], self.time[w]);
            if self.win[k] == nw && self.time[k] == nt && nw as usize != i {
                break;
            }
            self.win[k] = nw;
            self.time[k] = nt;
            k /= 2;
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.win.len() * 4 + self.time.len() * 8
    }
}

#[cfg(test)]
mod tests {
    use super::EventTree;

    #[test]
    fn root_is_the_earliest_after_random_updates() {
        let n = 37;
        let mut times: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64).collect();
        let mut tree = EventTree::new(n);
        for (i, &t) in times.iter().enumerate() {
            tree.set_lazy(i, t);
        }
        tree.rebuild();
        for step in 0..2000usize {
            let i = (step * 31 + step / 7) % n;
            // Coarse times make ties frequent: they must go to the lower index.
            times[i] = ((step * 104729) % 97) as f64;
            tree.update(i, times[i]);
            let best = (0..n)
                .min_by(|&a, &b| times[a].total_cmp(&times[b]).then(a.cmp(&b)))
                .unwrap();
            assert_eq!(tree.min(), (best, times[best]), "step {step}");
        }
    }
}
