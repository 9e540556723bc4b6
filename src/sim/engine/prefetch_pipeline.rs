//! The prefetch pipeline: the memory that the next events and kicks will read
//! is requested stages ahead (docs/sim.md, "Prefetch pipeline"). Only hints:
//! no result depends on it.

use super::Engine;
use super::parts::{BUCKET_PREFETCH_MAX, KICKS_AHEAD};
use crate::sim::events::cache_hints::{prefetch, prefetch_index};

impl Engine {
    /// One stage of fetching for each kick drawn ahead: the disk line, list
    /// record and cell of the one just drawn; the list and the 3x3 cells'
    /// counts and heads (where the partner is drawn) of the one after next;
    /// the listed neighbours of the next one. Each stage reads only what the
    /// previous one fetched, a kick (~2 events) earlier.
    pub(super) fn prefetch_kicks(&self) {
        if !self.derived.pipeline.on {
            // Small systems: only the next kick's disk and neighbours.
            self.prefetch_around(self.state.drive.kick_next);
            return;
        }
        let Some(ring) = &self.state.drive.kick_ring else {
            return;
        };
        let at = |m: usize| ring[(self.state.drive.kick_pos + m) % KICKS_AHEAD] as usize;
        let drawn = at(KICKS_AHEAD - 1);
        prefetch(&self.state.d[drawn]);
        prefetch(&self.derived.bk[drawn]);
        prefetch(&self.derived.cell[drawn]);
        let after_next = at(1);
        self.prefetch_list(after_next);
        // Three rows of three cells, ignoring the periodic wrap (a wrong
        // guess at the box edge only costs a useless fetch).
        let c = self.derived.cell[after_next] as usize;
        for row in [c.wrapping_sub(self.derived.ncx), c, c + self.derived.ncx] {
            for k in [row.wrapping_sub(1), row + 1] {
                prefetch_index(&self.derived.occupancy, k);
                prefetch_index(&self.derived.head, k);
            }
        }
        self.prefetch_listed(at(0));
    }

    /// Ask the cache for disk `i`'s bookkeeping and its listed neighbours, which
    /// its next prediction reads (at large N each is a miss to the L3 cache).
    #[inline]
    pub(super) fn prefetch_around(&self, i: usize) {
        prefetch(&self.state.d[i]);
        prefetch(&self.derived.cell[i]);
        self.prefetch_listed(i);
    }

    /// Fetch the neighbour list of disk `i` (its first and last entries: 12
    /// slots may straddle two lines). Reads `bk[i]`.
    #[inline]
    fn prefetch_list(&self, i: usize) {
        if self.derived.lists.on {
            let base = i * self.state.list_capacity;
            let m = self.derived.bk[i].nn as usize;
            prefetch_index(&self.derived.lists.nb, base);
            prefetch_index(&self.derived.lists.nb, base + m.saturating_sub(1));
        }
    }

    /// Fetch the lines of the disks in `i`'s neighbour list (which its
    /// prediction reads). Reads `bk[i]` and the list.
    #[inline]
    fn prefetch_listed(&self, i: usize) {
        if self.derived.lists.on {
            let base = i * self.state.list_capacity;
            for &k in &self.derived.lists.nb[base..base + self.derived.bk[i].nn as usize] {
                prefetch(&self.state.d[k as usize]);
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
        let cur = self.derived.calendar.current_bucket();
        if cur == self.derived.pipeline.bucket {
            return;
        }
        // Usually one step; after a jump or a re-binning (numbering restarts),
        // only the latest.
        let from = if cur < self.derived.pipeline.bucket || cur - self.derived.pipeline.bucket > 4 {
            cur
        } else {
            self.derived.pipeline.bucket + 1
        };
        self.derived.pipeline.bucket = cur;
        let cal = &self.derived.calendar;
        for b in from..=cur {
            for j in cal.bucket_members(b + 4).take(1) {
                cal.prefetch(j);
            }
            for j in cal.bucket_members(b + 3).take(BUCKET_PREFETCH_MAX) {
                cal.prefetch(j);
                prefetch(&self.state.d[j]);
                prefetch(&self.derived.bk[j]);
            }
            for j in cal.bucket_members(b + 2).take(BUCKET_PREFETCH_MAX) {
                self.prefetch_list(j);
                prefetch(&self.state.last_collision[j]);
                // The partner may be a SHELL code: then the fetches are useless.
                let p = self.derived.bk[j].ev_p as usize;
                prefetch_index(&self.state.d, p);
                prefetch_index(&self.derived.bk, p);
                prefetch_index(&self.state.last_collision, p);
                cal.prefetch(p);
            }
            for j in cal.bucket_members(b + 1).take(BUCKET_PREFETCH_MAX) {
                self.prefetch_listed(j);
                let p = self.derived.bk[j].ev_p as usize;
                if p < self.n() {
                    self.prefetch_list(p);
                    cal.prefetch_links(p);
                }
            }
        }
        for j in self
            .derived
            .calendar
            .current_members()
            .take(BUCKET_PREFETCH_MAX)
        {
            let p = self.derived.bk[j].ev_p as usize;
            if p < self.n() {
                self.prefetch_listed(p);
            }
        }
    }
}
