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
            node: super::resources::big_vec(
                2 * leaves,
                Node {
                    time: f64::INFINITY,
                    win: 0,
                },
            ),
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
        assert!(k < self.node.len(), "particle {i} is not in the tree");
        let node = self.node.as_mut_ptr();
        // SAFETY: k < 2 leaves = node.len() (checked above), and every index below
        // (k & !1, k | 1, k / 2) stays below k | 1 < node.len(). Unchecked access
        // because this climb runs about five times per collision.
        unsafe {
            (*node.add(k)).time = t;
            while k > 1 {
                // Sibling pair (k & !1, k | 1) decides the parent.
                let nw = better(*node.add(k & !1), *node.add(k | 1));
                k /= 2;
                let old = &mut *node.add(k);
                if old.time == nw.time && old.win == nw.win {
                    break;
                }
                *old = nw;
            }
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
    // Masks instead of a branch: which sibling wins is a coin flip, and LLVM
    // turns a plain `if` on it into a jump that is mispredicted half the time.
    let right = r.time < l.time;
    Node {
        time: select_f64(right, r.time, l.time),
        win: select_u32(right, r.win, l.win),
    }
}

/// `if c { a } else { b }` without a branch.
#[inline(always)]
pub(crate) fn select_u32(c: bool, a: u32, b: u32) -> u32 {
    let m = (c as u32).wrapping_neg();
    (a & m) | (b & !m)
}

/// `if c { a } else { b }` without a branch.
#[inline(always)]
pub(crate) fn select_f64(c: bool, a: f64, b: f64) -> f64 {
    let m = (c as u64).wrapping_neg();
    f64::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
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
