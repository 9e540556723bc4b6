//! The prefetch pipeline: the memory that the next events and kicks will read
//! is requested stages ahead (docs/sim.md, "Prefetch pipeline"). Only hints:
//! no result depends on it.

use super::{BUCKET_PREFETCH_MAX, Engine, KICKS_AHEAD};
use crate::sim::events::cache_hints::{prefetch, prefetch_index};


impl Engine {
    /// One stage of fetching for each kick drawn ahead: the disk line, list
    /// record and cell of the one just drawn; the list and the 3x3 cells'
    /// counts and heads (where the partner is drawn) of the one after next;
    /// the listed neighbours of the next one. Each stage reads only what the
    /// previous one fetched, a kick (~2 events) earlier.
    pub(super) fn prefetch_kicks(&self) {
        if !self.pipeline.on {
            // Small systems: only the next kick's disk and neighbours.
            self.prefetch_around(self.drive.kick_next);
            return;
        }
        let Some(ring) = &self.drive.kick_ring else {
            return;
        };
        let at = |m: usize| ring[(self.drive.kick_pos + m) % KICKS_AHEAD] as usize;
        let drawn = at(KICKS_AHEAD - 1);
        prefetch(&self.d[drawn]);
        prefetch(&self.bk[drawn]);
        prefetch(&self.cell[drawn]);
        let after_next = at(1);
        self.prefetch_list(after_next);
        // Three rows of three cells, ignoring the periodic wrap (a wrong
        // guess at the box edge only costs a useless fetch).
        let c = self.cell[after_next] as usize;
        for row in [c.wrapping_sub(self.ncx), c, c + self.ncx] {
            for k in [row.wrapping_sub(1), row + 1] {
                prefetch_index(&self.occupancy, k);
                prefetch_index(&self.head, k);
            }
        }
        self.prefetch_listed(at(0));
    }

    /// Ask the cache for disk `i`'s bookkeeping and its listed neighbours, which
    /// its next prediction reads (at large N each is a miss to the L3 cache).
    #[inline]
    pub(super) fn prefetch_around(&self, i: usize) {
        prefetch(&self.d[i]);
        prefetch(&self.cell[i]);
        self.prefetch_listed(i);
    }

    /// Fetch the neighbour list of disk `i` (its first and last entries: 12
    /// slots may straddle two lines). Reads `bk[i]`.
    #[inline]
    fn prefetch_list(&self, i: usize) {
        if self.lists.on {
            let base = i * self.lists.cap;
            let m = self.bk[i].nn as usize;
            prefetch_index(&self.lists.nb, base);
            prefetch_index(&self.lists.nb, base + m.saturating_sub(1));
        }
    }

    /// Fetch the lines of the disks in `i`'s neighbour list (which its
    /// prediction reads). Reads `bk[i]` and the list.
    #[inline]
    fn prefetch_listed(&self, i: usize) {
        if self.lists.on {
            let base = i * self.lists.cap;
            for &k in &self.lists.nb[base..base + self.bk[i].nn as usize] {
                prefetch(&self.d[k as usize]);
            }
        }
    }

    /// The prefetch pipeline over the calendar: when the current bucket moves
    /// on, fetch for the events of the next buckets, each stage reading only
    /// what an earlier stage fetched one bucket (~1.5 collisions) before:
    /// - bucket + 4: the calendar record of its first disk;
    /// - bucket + 3: (walking the bucket) the disks' records, lines and books;
    /// - bucket + 2: their lists, last collision times, and their partners'
    ///   lines, books and calendar records;
    /// - bucket + 1: their listed neighbours, the partners' lists and the
    ///   records the partners' calendar updates unlink;
    /// - the current bucket: the partners' listed neighbours.
    ///
    /// Events predicted meanwhile into these buckets are missed and stale
    /// ones fetched for nothing: it is only a hint, results never depend on it.
    pub(super) fn look_ahead(&mut self) {
        let cur = self.calendar.current_bucket();
        if cur == self.pipeline.bucket {
            return;
        }
        // Usually one step; after a jump or a re-binning (numbering restarts),
        // only the latest.
        let from = if cur < self.pipeline.bucket || cur - self.pipeline.bucket > 4 {
            cur
        } else {
            self.pipeline.bucket + 1
        };
        self.pipeline.bucket = cur;
        let cal = &self.calendar;
        for b in from..=cur {
            for j in cal.bucket_members(b + 4).take(1) {
                cal.prefetch(j);
            }
            for j in cal.bucket_members(b + 3).take(BUCKET_PREFETCH_MAX) {
                cal.prefetch(j);
                prefetch(&self.d[j]);
                prefetch(&self.bk[j]);
            }
            for j in cal.bucket_members(b + 2).take(BUCKET_PREFETCH_MAX) {
                self.prefetch_list(j);
                prefetch(&self.last_collision[j]);
                // The partner may be a SHELL code: then the fetches are useless.
                let p = self.bk[j].ev_p as usize;
                prefetch_index(&self.d, p);
                prefetch_index(&self.bk, p);
                prefetch_index(&self.last_collision, p);
                cal.prefetch(p);
            }
            for j in cal.bucket_members(b + 1).take(BUCKET_PREFETCH_MAX) {
                self.prefetch_listed(j);
                let p = self.bk[j].ev_p as usize;
                if p < self.n() {
                    self.prefetch_list(p);
                    cal.prefetch_links(p);
                }
            }
        }
        for j in self.calendar.current_members().take(BUCKET_PREFETCH_MAX) {
            let p = self.bk[j].ev_p as usize;
            if p < self.n() {
                self.prefetch_listed(p);
            }
        }
    }
}
