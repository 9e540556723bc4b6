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
    /// Node `k` (root 1, children `2k`, `2k + 1`, leaves at `leaves..2 leaves`):
    /// its winner and the winner's time, side by side so a climb touches one
    /// array.
    node: Vec<Node>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Node {
    /// Event time of the winner (infinity for padding leaves).
    time: f64,
    /// Winner: the leaf index with the earliest event in this subtree.
    win: u32,
}

impl EventTree {
    /// A tree over `n` particles, all without events (time infinity).
    pub fn new(n: usize) -> Self {
        let leaves = n.next_power_of_two().max(2);
        let mut t = EventTree {
            leaves,
            node: vec![
                Node {
                    time: f64::INFINITY,
                    win: 0
                };
                2 * leaves
            ],
        };
        for i in 0..leaves {
            t.node[leaves + i].win = i as u32;
        }
        t.rebuild();
        t
    }

    /// Set a leaf's time without fixing the tree (call [`Self::rebuild`] after).
    #[inline]
    pub fn set_lazy(&mut self, i: usize, t: f64) {
        self.node[self.leaves + i].time = t;
    }

    /// Recompute every internal node.
    pub fn rebuild(&mut self) {
        for k in (1..self.leaves).rev() {
            self.node[k] = better(self.node[2 * k], self.node[2 * k + 1]);
        }
    }

    /// Particle with the earliest event, and its time.
    #[inline]
    pub fn min(&self) -> (usize, f64) {
        (self.node[1].win as usize, self.node[1].time)
    }

    /// Event time of particle `i`.
    #[inline]
    pub fn time(&self, i: usize) -> f64 {
        self.node[self.leaves + i].time
    }

    /// Give particle `i` the event time `t`.
    #[inline]
    pub fn update(&mut self, i: usize, t: f64) {
        let mut k = self.leaves + i;
        self.node[k].time = t;
        while k > 1 {
            // Sibling pair (k & !1, k | 1) decides the parent.
            let nw = better(self.node[k & !1], self.node[k | 1]);
            k /= 2;
            let old = &mut self.node[k];
            if *old == nw && nw.win as usize != i {
                break;
            }
            *old = nw;
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.node.len() * std::mem::size_of::<Node>()
    }
}

/// The earlier of two sibling nodes; ties go to the left (lower index), so the
/// order of events is reproducible.
#[inline]
fn better(l: Node, r: Node) -> Node {
    if r.time < l.time { r } else { l }
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
