//! The event calendar: a tournament tree over one event time per particle.
//!
//! Each particle owns exactly one pending event (its earliest predicted collision
//! or cell crossing), so the calendar never grows and never allocates after
//! construction. Leaf `i` holds particle `i`; every internal node stores the leaf
//! with the earlier time of its two children, so the root is the next event and an
//! update climbs one path of length log2(N).

pub struct EventTree {
    /// Number of leaves (a power of two >= number of particles).
    leaves: usize,
    /// `node[k]` for k in 1..leaves: winning particle of the subtree at k.
    node: Vec<u32>,
}

impl EventTree {
    pub fn new(n: usize, times: &[f64]) -> Self {
        let leaves = n.next_power_of_two().max(2);
        let mut t = EventTree {
            leaves,
            node: vec![0; leaves],
        };
        t.rebuild(n, times);
        t
    }

    /// Recompute every internal node (after all event times changed).
    pub fn rebuild(&mut self, n: usize, times: &[f64]) {
        for k in (1..self.leaves).rev() {
            let (a, b) = (self.child(2 * k, n), self.child(2 * k + 1, n));
            self.node[k] = Self::earlier(a, b, times);
        }
    }

    /// Winner of node `k` (internal or leaf); u32::MAX for an empty leaf.
    #[inline]
    fn child(&self, k: usize, n: usize) -> u32 {
        if k >= self.leaves {
            let i = k - self.leaves;
            if i < n { i as u32 } else { u32::MAX }
        } else {
            self.node[k]
        }
    }

    #[inline]
    fn earlier(a: u32, b: u32, times: &[f64]) -> u32 {
        if b == u32::MAX {
            return a;
        }
        if a == u32::MAX {
            return b;
        }
        // Ties go to the lower index, so the order of events is reproducible.
        if times[b as usize] < times[a as usize] { b } else { a }
    }

    /// Particle with the earliest event.
    #[inline]
    pub fn min(&self) -> usize {
        self.node[1] as usize
    }

    /// Re-establish the tree after the event time of particle `i` changed.
    #[inline]
    pub fn update(&mut self, i: usize, times: &[f64]) {
        let n = times.len();
        let mut k = (i + self.leaves) / 2;
        while k >= 1 {
            let (a, b) = (self.child(2 * k, n), self.child(2 * k + 1, n));
            self.node[k] = Self::earlier(a, b, times);
            k /= 2;
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.node.len() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::EventTree;

    #[test]
    fn root_is_the_earliest_after_random_updates() {
        let mut times: Vec<f64> = (0..37).map(|i| ((i * 7919) % 101) as f64).collect();
        let mut tree = EventTree::new(times.len(), &times);
        for step in 0..500usize {
            let i = (step * 31) % times.len();
            times[i] = ((step * 104729) % 997) as f64 * 0.5;
            tree.update(i, &times);
            let best = (0..times.len())
                .min_by(|&a, &b| times[a].total_cmp(&times[b]).then(a.cmp(&b)))
                .unwrap();
            assert_eq!(tree.min(), best, "step {step}");
        }
    }
}
