//! Neighbour lists with a shell (Smallenburg): disk `i` stays within `shell` of
//! its list centre, and its list holds every disk whose centre is within
//! sigma_ij + 2 shell of it; leaving the shell rebuilds that one list.

use super::Engine;
use crate::sim::big_vec::big_vec;
use crate::sim::events::disk::{Disk, NONE};
use crate::sim::events::pair_scan::nearest_image;

impl Engine {
    /// Time from now until disk `a` (= disk `i` at the current time) is `shell`
    /// away from its list centre.
    #[inline]
    pub(super) fn shell_time(&self, i: usize, a: &Disk) -> f64 {
        // No nearest image: positions are wrapped into the box only where the
        // centre is set (shell exits, full rebuilds), so a disk is never more
        // than `shell` from its centre in unwrapped coordinates.
        let dx = a.x - self.derived.bk[i].ox;
        let dy = a.y - self.derived.bk[i].oy;
        let aa = a.vx * a.vx + a.vy * a.vy;
        if aa == 0.0 {
            return f64::INFINITY;
        }
        let bb = dx * a.vx + dy * a.vy;
        let c = dx * dx + dy * dy - self.derived.lists.shell * self.derived.lists.shell;
        if c >= 0.0 {
            return 0.0;
        }
        // c < 0: one positive root; this form avoids cancellation when bb > 0.
        let root = (bb * bb - aa * c).sqrt();
        if bb >= 0.0 {
            -c / (bb + root)
        } else {
            (root - bb) / aa
        }
    }

    /// Disk `i` left its shell: centre its list on where it is now. With lists
    /// a disk's cell is that of its list centre, so this is also where its
    /// position is wrapped into the box and its cell changes (no crossing events).
    pub(super) fn shell_exit(&mut self, i: usize) {
        self.state.stats.shell_exits += 1;
        self.advance(i);
        self.wrap_into_box(i);
        let c = self.cell_of(self.state.d[i].x, self.state.d[i].y);
        if c != self.derived.cell[i] as usize {
            self.remove(i);
            self.insert(i, c);
        }
        let base = i * self.state.list_capacity;
        for k in 0..self.derived.bk[i].nn as usize {
            let j = self.derived.lists.nb[base + k] as usize;
            self.unlist(j, i as u32);
        }
        self.derived.bk[i].nn = 0;
        self.derived.bk[i].ox = self.state.d[i].x;
        self.derived.bk[i].oy = self.state.d[i].y;
        self.scan_list(i, true);
        if self.derived.lists.overflow {
            self.grow_lists(2 * self.state.list_capacity);
        } else {
            self.predict(i);
        }
    }

    /// Give every list room for `cap` disks (at most the packing bound) and
    /// rebuild them all, with every event predicted anew.
    fn grow_lists(&mut self, cap: usize) {
        self.state.list_capacity = cap.min(self.derived.lists.cap_max);
        self.derived.lists.nb = big_vec(self.n() * self.state.list_capacity, NONE);
        self.reschedule_all();
    }

    /// Remove `i` from the list of `j`.
    fn unlist(&mut self, j: usize, i: u32) {
        let base = j * self.state.list_capacity;
        let m = self.derived.bk[j].nn as usize;
        let list = &mut self.derived.lists.nb[base..base + m];
        let k = list
            .iter()
            .position(|&x| x == i)
            .expect("neighbour lists are symmetric");
        list[k] = list[m - 1];
        self.derived.bk[j].nn -= 1;
    }

    fn push_list(&mut self, i: usize, j: usize) {
        let m = self.derived.bk[i].nn as usize;
        if m == self.state.list_capacity {
            self.derived.lists.overflow = true;
            return;
        }
        self.derived.lists.nb[i * self.state.list_capacity + m] = j as u32;
        self.derived.bk[i].nn += 1;
    }

    /// Fill the list of `i` with every disk whose centre is within the list
    /// range of its own, from the 5x5 cells around `i` (a disk is within
    /// `shell` of its centre, so it is within sigma_max + 3 shell <= two cells
    /// of `i`). With `both`, also put `i` in their lists.
    fn scan_list(&mut self, i: usize, both: bool) {
        let c = self.derived.cell[i] as usize;
        let (cx, cy) = (c % self.derived.ncx, c / self.derived.ncx);
        let (oxi, oyi, ri) = (
            self.derived.bk[i].ox,
            self.derived.bk[i].oy,
            self.state.d[i].radius,
        );
        // Cells two away are needed only on a side where the centre is within
        // `reach - w` of its cell's edge (reach < 2 w): about 12 cells instead of 25.
        let reach = (ri + self.derived.rmax + 2.0 * self.derived.lists.shell) * (1.0 + 1e-9);
        let (fx, fy) = (
            oxi - cx as f64 * self.derived.wx,
            oyi - cy as f64 * self.derived.wy,
        );
        let (x0, x1) = (
            if fx + self.derived.wx < reach { -2 } else { -1 },
            if 2.0 * self.derived.wx - fx < reach {
                2
            } else {
                1
            },
        );
        let (y0, y1) = (
            if fy + self.derived.wy < reach { -2 } else { -1 },
            if 2.0 * self.derived.wy - fy < reach {
                2
            } else {
                1
            },
        );
        for dy in y0..=y1 {
            let (ny, _) = Self::wrap(cy, dy, self.derived.ncy, self.derived.ly);
            for dx in x0..=x1 {
                let (nx, _) = Self::wrap(cx, dx, self.derived.ncx, self.derived.lx);
                let mut j = self.derived.head[ny * self.derived.ncx + nx];
                while j != NONE {
                    let ju = j as usize;
                    j = self.state.d[ju].next;
                    if ju == i {
                        continue;
                    }
                    let ddx = nearest_image(self.derived.bk[ju].ox - oxi, self.derived.lx);
                    let ddy = nearest_image(self.derived.bk[ju].oy - oyi, self.derived.ly);
                    let range = ri + self.state.d[ju].radius + 2.0 * self.derived.lists.shell;
                    if ddx * ddx + ddy * ddy < range * range {
                        self.push_list(i, ju);
                        if both {
                            self.push_list(ju, i);
                        }
                    }
                }
            }
        }
    }

    /// Centre every list on the current positions and fill them.
    pub(super) fn build_all_lists(&mut self) {
        for i in 0..self.n() {
            self.derived.bk[i].ox = self.state.d[i].x;
            self.derived.bk[i].oy = self.state.d[i].y;
        }
        loop {
            self.derived.lists.overflow = false;
            for b in &mut self.derived.bk {
                b.nn = 0;
            }
            for i in 0..self.n() {
                self.scan_list(i, false);
            }
            if !self.derived.lists.overflow {
                return;
            }
            assert!(
                self.state.list_capacity < self.derived.lists.cap_max,
                "a neighbour list exceeds its packing bound {}: overlapping disks",
                self.derived.lists.cap_max
            );
            self.state.list_capacity =
                (2 * self.state.list_capacity).min(self.derived.lists.cap_max);
            self.derived.lists.nb = big_vec(self.n() * self.state.list_capacity, NONE);
        }
    }

    /// Start the lists over with capacity `cap` (to exercise their growth).
    #[cfg(test)]
    pub(crate) fn set_list_capacity(&mut self, cap: usize) {
        self.grow_lists(cap);
    }

    /// Current list capacity per disk.
    pub fn list_capacity(&self) -> usize {
        self.state.list_capacity
    }

    /// Check the neighbour-list invariants against all pairs: every disk is within
    /// `shell` of its centre, and `j` is in the list of `i` exactly when their
    /// centres are within range. The error names the first violation.
    pub fn check_lists(&self) -> Result<(), String> {
        if !self.derived.lists.on {
            return Err("neighbour lists are not in use".into());
        }
        let near = |i: usize, x: f64, y: f64| {
            let dx = nearest_image(x - self.derived.bk[i].ox, self.derived.lx);
            let dy = nearest_image(y - self.derived.bk[i].oy, self.derived.ly);
            dx * dx + dy * dy
        };
        let list = |i: usize| {
            &self.derived.lists.nb[i * self.state.list_capacity
                ..i * self.state.list_capacity + self.derived.bk[i].nn as usize]
        };
        for i in 0..self.n() {
            let d = &self.state.d[i];
            let dt = self.state.now - d.t;
            // Unwrapped, without a nearest image: shell times rely on it.
            let (dx, dy) = (
                d.x + d.vx * dt - self.derived.bk[i].ox,
                d.y + d.vy * dt - self.derived.bk[i].oy,
            );
            let r2 = dx * dx + dy * dy;
            if r2 > self.derived.lists.shell * self.derived.lists.shell * (1.0 + 1e-9) {
                return Err(format!(
                    "disk {i} is {} from its centre, shell {}",
                    r2.sqrt(),
                    self.derived.lists.shell
                ));
            }
            for j in 0..self.n() {
                if j == i {
                    continue;
                }
                let range = d.radius + self.state.d[j].radius + 2.0 * self.derived.lists.shell;
                let inside = near(i, self.derived.bk[j].ox, self.derived.bk[j].oy) < range * range;
                if inside != list(i).contains(&(j as u32)) {
                    return Err(format!(
                        "disk {j} is wrongly {} the list of {i}",
                        if inside { "missing from" } else { "in" }
                    ));
                }
            }
        }
        Ok(())
    }
}
