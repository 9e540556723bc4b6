//! An O(1) event calendar: Paul's calendar queue (G. Paul, J. Comput. Phys. 221,
//! 615 (2007); also in Smallenburg's EDMD and DynamO): one pending event time
//! per particle, the earliest read in O(1).
//!
//! Time is cut into buckets of width `dt`, numbered from the origin `t0`
//! (`b(t) = floor((t - t0) / dt)`), and `nb` (a power of two) consecutive buckets
//! form a "year" held in a ring of doubly linked lists. With `cur` the current
//! bucket and `limit` the end of the year, every particle with a finite time is
//! in exactly one place:
//! - the heap: `b(t) <= cur`, a small binary heap of (time, index);
//! - the ring: `cur < b(t) < limit` (with `limit - cur <= nb`, so each ring slot
//!   holds one bucket);
//! - the overflow list: `b(t) >= limit`, re-binned when the year ends.
//!
//! `b` is non-decreasing in `t`, so every heap time is earlier than every ring or
//! overflow time and the heap top is the global minimum. Whatever goes below the
//! current bucket's end lands in the heap, so times earlier than the minimum (the
//! engine's kicks) are handled, and any time is accepted. Ties go to the lower
//! index. When the heap empties, the next buckets are moved into
//! it, so [`EventCalendar::min`] is a read (`&self`).
//!
//! Bucket width: [`EventCalendar::rebuild`] chooses `dt` for [`PER_BUCKET`]
//! events per bucket from the spread of the finite times (for exponential waiting
//! times of mean tau the event rate is n / tau and tau = median / ln 2), and at
//! every year's end the observed events per bucket re-tune `dt` if they are off
//! by more than a factor [`RETUNE`] (the collision rate changes, e.g. during
//! compression). `dt` only affects speed, never the answers.

use super::cache_hints::{prefetch, prefetch_index};
use crate::sim::big_vec::big_vec;

/// No particle (end of a list).
const NONE: u32 = u32::MAX;
/// The bucket of every time beyond 2^62 buckets (and of infinity).
const LAST_BUCKET: u64 = 1 << 62;
/// Heap capacity kept after a rebuild (a bucket holds a few events).
const HEAP_START: usize = 64;
/// Target events per bucket (measured in docs/calendar.md).
pub const PER_BUCKET: f64 = 2.0;
/// Re-tune the bucket width when a year's events per bucket leave
/// [PER_BUCKET / RETUNE, PER_BUCKET RETUNE].
pub const RETUNE: f64 = 3.0;

/// One particle in 16 bytes: its time and its links in a ring or overflow list.
/// Where it is follows from its time (module docs); in the heap, `prev` holds
/// its heap position.
#[derive(Clone, Copy, Debug)]
struct Slot {
    time: f64,
    prev: u32,
    next: u32,
}

/// Where a particle is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Place {
    /// In the heap, at this position.
    Heap(usize),
    /// In this list: a ring slot (`0..nb`) or the overflow list (`nb`).
    List(u32),
    /// Nowhere: its time is infinite.
    Nowhere,
}

/// A heap entry: the time is kept inline so sifting reads one array.
#[derive(Clone, Copy, Debug)]
struct Entry {
    time: f64,
    idx: u32,
}

/// Earlier time first; equal times go to the lower index (determinism).
#[inline(always)]
fn before(a: Entry, b: Entry) -> bool {
    a.time < b.time || (a.time == b.time && a.idx < b.idx)
}

/// The particles of one bucket ([`EventCalendar::bucket_members`]). A
/// particle's record is read only when the one after it is asked for, so taking
/// the first reads nothing but the bucket's head.
pub struct BucketMembers<'a> {
    slot: &'a [Slot],
    /// The particle handed out last (NONE before the first and at the end).
    at: u32,
    first: u32,
}

impl Iterator for BucketMembers<'_> {
    type Item = usize;

    #[inline]
    fn next(&mut self) -> Option<usize> {
        self.at = if self.first != NONE {
            std::mem::replace(&mut self.first, NONE)
        } else if self.at != NONE {
            self.slot[self.at as usize].next
        } else {
            NONE
        };
        (self.at != NONE).then_some(self.at as usize)
    }
}

pub struct EventCalendar {
    slot: Vec<Slot>,
    /// Heads of the ring lists (`0..nb`) and of the overflow list (`nb`).
    head: Vec<u32>,
    /// `nb - 1`: ring slot of bucket `b` is `b & mask`.
    mask: u64,
    heap: Vec<Entry>,
    t0: f64,
    dt: f64,
    inv_dt: f64,
    cur: u64,
    limit: u64,
    /// Particles in the ring lists.
    in_ring: usize,
    /// Particles with a finite time.
    finite: usize,
    /// This year's heap insertions and bucket advances (events per bucket).
    arrivals: u64,
    advances: u64,
}

impl EventCalendar {
    /// A calendar of `n` particles, all without events (time infinity).
    pub fn new(n: usize) -> Self {
        assert!(
            n < 1 << 30,
            "{n} particles exceed the calendar's 2^30 limit"
        );
        let nb = n.next_power_of_two().max(2);
        let mut c = EventCalendar {
            slot: big_vec(
                n,
                Slot {
                    time: f64::INFINITY,
                    prev: NONE,
                    next: NONE,
                },
            ),
            head: big_vec(nb + 1, NONE),
            mask: nb as u64 - 1,
            heap: Vec::with_capacity(HEAP_START),
            t0: 0.0,
            dt: 1.0,
            inv_dt: 1.0,
            cur: 0,
            limit: nb as u64,
            in_ring: 0,
            finite: 0,
            arrivals: 0,
            advances: 0,
        };
        c.rebuild();
        c
    }

    /// Set a particle's time without placing it (call [`Self::rebuild`] after).
    #[inline]
    pub fn set_lazy(&mut self, i: usize, t: f64) {
        self.slot[i].time = t;
    }

    /// Re-choose the bucket width from the current times and place every particle.
    pub fn rebuild(&mut self) {
        let lo = self
            .slot
            .iter()
            .map(|s| s.time)
            .filter(|t| t.is_finite())
            .fold(f64::INFINITY, f64::min);
        // Times tied at the earliest share a bucket whatever the width: the
        // width comes from the spread of the others.
        let mut spread: Vec<f64> = self
            .slot
            .iter()
            .map(|s| s.time - lo)
            .filter(|&d| d > 0.0 && d.is_finite())
            .collect();
        let m = spread.len();
        let mut dt = 1.0;
        if m > 0 {
            let (_, median, _) = spread.select_nth_unstable_by(m / 2, f64::total_cmp);
            dt = PER_BUCKET * *median / (std::f64::consts::LN_2 * m as f64);
        }
        if dt <= 0.0 || !dt.is_finite() {
            dt = 1.0;
        }
        self.rebin_all(dt);
        // A start with many tied times may have grown the heap: give it back.
        self.heap.shrink_to(HEAP_START.max(2 * self.heap.len()));
    }

    /// Particle with the earliest time (ties: the lower index), and its time;
    /// `(0, infinity)` when no particle has a finite time.
    #[inline]
    pub fn min(&self) -> (usize, f64) {
        match self.heap.first() {
            Some(e) => (e.idx as usize, e.time),
            None => (0, f64::INFINITY),
        }
    }

    /// Time of particle `i`.
    #[inline]
    pub fn time(&self, i: usize) -> f64 {
        self.slot[i].time
    }

    /// Give particle `i` the time `t` (any time, including infinity; not NaN).
    #[inline]
    pub fn update(&mut self, i: usize, t: f64) {
        assert!(i < self.slot.len(), "particle {i} is not in the calendar");
        debug_assert!(!t.is_nan(), "event time of particle {i} is NaN");
        let b = self.bucket(t);
        let was = self.place_of(i);
        if let (Place::Heap(p), true) = (was, b <= self.cur && t != f64::INFINITY) {
            // Stays in the heap: change the key in place.
            let old = self.heap[p];
            let new = Entry {
                time: t,
                idx: old.idx,
            };
            self.heap[p] = new;
            self.slot[i].time = t;
            if before(new, old) {
                self.sift_up(p);
            } else {
                self.sift_down(p);
            }
            return;
        }
        self.detach(i, was);
        self.place(i, t, b);
        if self.heap.is_empty() {
            self.advance();
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.slot.len() * std::mem::size_of::<Slot>()
            + self.head.len() * std::mem::size_of::<u32>()
            + self.heap.capacity() * std::mem::size_of::<Entry>()
    }

    /// Current bucket width.
    pub fn bucket_width(&self) -> f64 {
        self.dt
    }

    /// The current bucket (that of the earliest time). It grows as time runs
    /// and restarts from 0 when the width is re-tuned or after a rebuild.
    #[inline]
    pub fn current_bucket(&self) -> u64 {
        self.cur
    }

    /// The particles of the current bucket (those in the heap), in no order.
    #[inline]
    pub fn current_members(&self) -> impl Iterator<Item = usize> + '_ {
        self.heap.iter().map(|e| e.idx as usize)
    }

    /// The particles whose times are in bucket `b`, a bucket after the current
    /// one within this year (in no order); none for any other `b`. Names the
    /// events a few buckets ahead without a search, so that their data can be
    /// fetched early: the walk reads one calendar record per particle.
    #[inline]
    pub fn bucket_members(&self, b: u64) -> BucketMembers<'_> {
        let first = if self.cur < b && b < self.limit {
            self.head[(b & self.mask) as usize]
        } else {
            NONE
        };
        BucketMembers {
            slot: &self.slot,
            at: NONE,
            first,
        }
    }

    /// Start fetching the calendar record of particle `i` (read by any update
    /// of it and by a walk of its bucket); any `i` is allowed (a useless fetch
    /// if it is not a particle).
    #[inline]
    pub fn prefetch(&self, i: usize) {
        prefetch_index(&self.slot, i);
    }

    /// Start fetching the records linked to particle `i` in its list: taking
    /// it out of a ring or overflow list (to give it a new time) writes them.
    /// Reads `i`'s own record, so fetch that one first ([`Self::prefetch`]).
    #[inline]
    pub fn prefetch_links(&self, i: usize) {
        if let Place::List(_) = self.place_of(i) {
            let Slot { prev, next, .. } = self.slot[i];
            for k in [prev, next] {
                if k != NONE {
                    prefetch(&self.slot[k as usize]);
                }
            }
        }
    }

    /// Bucket of time `t`: non-decreasing in `t`; times before `t0` (and NaN)
    /// fall in bucket 0, huge ones and infinity in [`LAST_BUCKET`].
    #[inline]
    fn bucket(&self, t: f64) -> u64 {
        let x = (t - self.t0) * self.inv_dt;
        // Clamps by comparisons (maxsd/minsd), then a plain conversion: the
        // saturating `as u64` costs about 14 instructions, once per update.
        let x = if x > 0.0 { x } else { 0.0 };
        let x = if x < LAST_BUCKET as f64 {
            x
        } else {
            LAST_BUCKET as f64
        };
        // SAFETY: 0 <= x <= 2^62, finite, so it fits an i64.
        unsafe { x.to_int_unchecked::<i64>() as u64 }
    }

    #[inline]
    fn overflow(&self) -> u32 {
        (self.mask + 1) as u32
    }

    /// Forget the placement, set the bucket width and place every particle anew,
    /// with the earliest finite time in bucket 0 = the current one.
    fn rebin_all(&mut self, dt: f64) {
        self.t0 = self
            .slot
            .iter()
            .map(|s| s.time)
            .filter(|t| t.is_finite())
            .fold(f64::INFINITY, f64::min);
        if !self.t0.is_finite() {
            self.t0 = 0.0;
        }
        self.dt = dt;
        self.inv_dt = 1.0 / dt;
        self.cur = 0;
        self.limit = self.mask + 1;
        self.head.fill(NONE);
        self.heap.clear();
        self.in_ring = 0;
        self.finite = 0;
        self.arrivals = 0;
        self.advances = 0;
        for i in 0..self.slot.len() {
            let t = self.slot[i].time;
            self.place(i, t, self.bucket(t));
        }
        // The earliest finite time is in bucket 0 = cur, so the heap is not
        // empty unless no time is finite.
    }

    /// Put particle `i` (in no structure) at time `t`, in bucket `b = bucket(t)`.
    #[inline]
    fn place(&mut self, i: usize, t: f64, b: u64) {
        self.slot[i].time = t;
        if t == f64::INFINITY {
            return;
        }
        self.finite += 1;
        if b <= self.cur {
            self.heap_push(i, t);
        } else if b < self.limit {
            self.link((b & self.mask) as u32, i);
            self.in_ring += 1;
        } else {
            self.link(self.overflow(), i);
        }
    }

    /// Where particle `i` is, from its time.
    #[inline]
    fn place_of(&self, i: usize) -> Place {
        let Slot { time, prev, .. } = self.slot[i];
        if time == f64::INFINITY {
            return Place::Nowhere;
        }
        let b = self.bucket(time);
        if b <= self.cur {
            Place::Heap(prev as usize)
        } else if b < self.limit {
            Place::List((b & self.mask) as u32)
        } else {
            Place::List(self.overflow())
        }
    }

    /// Take particle `i` out of `place` (where it is).
    #[inline]
    fn detach(&mut self, i: usize, place: Place) {
        match place {
            Place::Nowhere => return,
            Place::Heap(p) => self.heap_remove(p),
            Place::List(l) => {
                self.unlink(l, i);
                if l != self.overflow() {
                    self.in_ring -= 1;
                }
            }
        }
        self.finite -= 1;
    }

    /// The heap is empty: move the next non-empty bucket into it.
    fn advance(&mut self) {
        while self.heap.is_empty() && self.finite > 0 {
            if self.in_ring == 0 {
                // Everything left is beyond the year: jump to its first bucket.
                let mut first = u64::MAX;
                let mut j = self.head[self.overflow() as usize];
                while j != NONE {
                    first = first.min(self.bucket(self.slot[j as usize].time));
                    j = self.slot[j as usize].next;
                }
                self.advances = self.advances.saturating_add(first - self.cur);
                self.cur = first;
                if self.retuned() {
                    return;
                }
                self.new_year();
                continue;
            }
            self.cur += 1;
            self.advances += 1;
            if self.cur == self.limit {
                if self.retuned() {
                    return;
                }
                self.new_year();
            }
            let s = (self.cur & self.mask) as usize;
            let mut j = std::mem::replace(&mut self.head[s], NONE);
            while j != NONE {
                let next = self.slot[j as usize].next;
                self.in_ring -= 1;
                self.heap_push(j as usize, self.slot[j as usize].time);
                j = next;
            }
        }
    }

    /// At a year's end: if the events per bucket were off target by more than
    /// [`RETUNE`], re-choose the width for the observed rate and place every
    /// particle anew (O(n), once per year at most).
    fn retuned(&mut self) -> bool {
        let off = self.arrivals as f64 / self.advances as f64 / PER_BUCKET;
        if self.advances <= self.mask / 2 || (1.0 / RETUNE..=RETUNE).contains(&off) {
            return false;
        }
        self.rebin_all(self.dt / off.clamp(1.0 / 64.0, 64.0));
        true
    }

    /// Start a year at `cur`: move the overflow times now within reach.
    fn new_year(&mut self) {
        self.limit = self.cur.saturating_add(self.mask + 1);
        self.arrivals = 0;
        self.advances = 0;
        let of = self.overflow();
        let mut j = self.head[of as usize];
        while j != NONE {
            let ju = j as usize;
            let next = self.slot[ju].next;
            let t = self.slot[ju].time;
            let b = self.bucket(t);
            if b < self.limit {
                self.unlink(of, ju);
                if b <= self.cur {
                    self.heap_push(ju, t);
                } else {
                    self.link((b & self.mask) as u32, ju);
                    self.in_ring += 1;
                }
            }
            j = next;
        }
    }

    #[inline]
    fn link(&mut self, list: u32, i: usize) {
        let h = self.head[list as usize];
        self.slot[i].prev = NONE;
        self.slot[i].next = h;
        if h != NONE {
            self.slot[h as usize].prev = i as u32;
        }
        self.head[list as usize] = i as u32;
    }

    #[inline]
    fn unlink(&mut self, list: u32, i: usize) {
        let Slot { prev, next, .. } = self.slot[i];
        if prev != NONE {
            self.slot[prev as usize].next = next;
        } else {
            self.head[list as usize] = next;
        }
        if next != NONE {
            self.slot[next as usize].prev = prev;
        }
    }

    #[inline]
    fn heap_push(&mut self, i: usize, t: f64) {
        self.arrivals += 1;
        self.heap.push(Entry {
            time: t,
            idx: i as u32,
        });
        self.sift_up(self.heap.len() - 1);
    }

    #[inline]
    fn heap_remove(&mut self, p: usize) {
        let last = self.heap.pop().expect("a heap particle is in the heap");
        if p < self.heap.len() {
            self.heap[p] = last;
            if p > 0 && before(last, self.heap[(p - 1) / 2]) {
                self.sift_up(p);
            } else {
                self.sift_down(p);
            }
        }
    }

    #[inline]
    fn sift_up(&mut self, mut p: usize) {
        let e = self.heap[p];
        while p > 0 {
            let q = (p - 1) / 2;
            let parent = self.heap[q];
            if !before(e, parent) {
                break;
            }
            self.heap[p] = parent;
            self.slot[parent.idx as usize].prev = p as u32;
            p = q;
        }
        self.heap[p] = e;
        self.slot[e.idx as usize].prev = p as u32;
    }

    #[inline]
    fn sift_down(&mut self, mut p: usize) {
        let e = self.heap[p];
        let len = self.heap.len();
        loop {
            let l = 2 * p + 1;
            if l >= len {
                break;
            }
            let r = l + 1;
            let c = if r < len && before(self.heap[r], self.heap[l]) {
                r
            } else {
                l
            };
            let child = self.heap[c];
            if !before(child, e) {
                break;
            }
            self.heap[p] = child;
            self.slot[child.idx as usize].prev = p as u32;
            p = c;
        }
        self.heap[p] = e;
        self.slot[e.idx as usize].prev = p as u32;
    }

    /// Check every invariant of the module docs; the error names the first
    /// violation.
    #[cfg(test)]
    fn check(&self) -> Result<(), String> {
        let (mut heap, mut ring, mut over, mut finite) = (0, 0, 0, 0);
        let mut member = vec![None; self.slot.len()];
        for l in 0..self.head.len() {
            let (mut j, mut prev) = (self.head[l], NONE);
            while j != NONE {
                if self.slot[j as usize].prev != prev || member[j as usize].is_some() {
                    return Err(format!("list {l} links broken at {j}"));
                }
                member[j as usize] = Some(Place::List(l as u32));
                (prev, j) = (j, self.slot[j as usize].next);
            }
        }
        for (p, e) in self.heap.iter().enumerate() {
            if member[e.idx as usize].is_some() {
                return Err(format!(
                    "particle {} in the heap twice or also listed",
                    e.idx
                ));
            }
            member[e.idx as usize] = Some(Place::Heap(p));
        }
        for (i, s) in self.slot.iter().enumerate() {
            let place = self.place_of(i);
            if place != member[i].unwrap_or(Place::Nowhere) {
                return Err(format!(
                    "particle {i} at {} is at {:?}, not {place:?}",
                    s.time, member[i]
                ));
            }
            match place {
                Place::Nowhere => {}
                Place::Heap(p) => {
                    heap += 1;
                    finite += 1;
                    if self.heap[p].time != s.time {
                        return Err(format!(
                            "particle {i} has time {} in the heap",
                            self.heap[p].time
                        ));
                    }
                }
                Place::List(l) if l == self.overflow() => {
                    over += 1;
                    finite += 1;
                }
                Place::List(_) => {
                    ring += 1;
                    finite += 1;
                }
            }
        }
        for p in 1..self.heap.len() {
            if before(self.heap[p], self.heap[(p - 1) / 2]) {
                return Err(format!("heap order broken at {p}"));
            }
        }
        if heap != self.heap.len()
            || ring != self.in_ring
            || finite != self.finite
            || self.limit - self.cur > self.mask + 1
            || (self.heap.is_empty() && finite > 0)
        {
            return Err(format!(
                "counts: heap {heap}/{}, ring {ring}/{}, finite {finite}/{}, overflow {over}",
                self.heap.len(),
                self.in_ring,
                self.finite
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::EventCalendar;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Exp};

    /// The reference: lowest index among the earliest times.
    fn brute_min(times: &[f64]) -> (usize, f64) {
        let best = (0..times.len())
            .min_by(|&a, &b| times[a].total_cmp(&times[b]).then(a.cmp(&b)))
            .unwrap();
        (best, times[best])
    }

    /// The members the look-ahead API names, against the times: the current
    /// bucket holds every finite time of a bucket up to the current one, and
    /// each later bucket of the year exactly the times that fall in it.
    /// Returns how many particles the next five buckets named.
    fn members_match(cal: &EventCalendar, times: &[f64]) -> Result<usize, String> {
        let sorted = |mut v: Vec<usize>| {
            v.sort_unstable();
            v
        };
        let cur = cal.current_bucket();
        let want = |keep: &dyn Fn(u64) -> bool| {
            (0..times.len())
                .filter(|&i| times[i].is_finite() && keep(cal.bucket(times[i])))
                .collect::<Vec<_>>()
        };
        if sorted(cal.current_members().collect()) != want(&|b| b <= cur) {
            return Err(format!("current bucket {cur} members differ"));
        }
        let mut named = 0;
        for b in cur + 1..cur + 6 {
            let expect = if b < cal.limit {
                want(&|bt| bt == b)
            } else {
                vec![]
            };
            if sorted(cal.bucket_members(b).collect()) != expect {
                return Err(format!("bucket {b} (current {cur}) members differ"));
            }
            named += expect.len();
        }
        // Nothing is named for buckets that are not ahead of the current one.
        if cal.bucket_members(cur).next().is_some()
            || cal.bucket_members(cur.wrapping_sub(1)).next().is_some()
        {
            return Err(format!("members named for bucket {cur} or before"));
        }
        Ok(named)
    }

    /// Random operations against the brute-force reference. Each step picks one
    /// of: pop the minimum and reschedule it later by an exponential wait (the
    /// EDMD pattern), update a random particle to a time between the last popped
    /// time and far ahead (earlier than the minimum included), to infinity, or a
    /// bulk `set_lazy` + `rebuild`. `coarse` rounds times to a grid (ties).
    fn against_brute_force(n: usize, steps: usize, coarse: f64, mean_wait: f64, seed: u64) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let wait = Exp::new(1.0 / mean_wait).unwrap();
        let round = |t: f64| {
            if coarse > 0.0 {
                (t / coarse).ceil() * coarse
            } else {
                t
            }
        };
        let mut times: Vec<f64> = (0..n).map(|_| round(wait.sample(&mut rng) + 0.0)).collect();
        let mut cal = EventCalendar::new(n);
        for (i, &t) in times.iter().enumerate() {
            cal.set_lazy(i, t);
        }
        cal.rebuild();
        let mut now = 0.0f64;
        for step in 0..steps {
            let (i, t) = brute_min(&times);
            assert_eq!(cal.min(), (i, t), "n {n} seed {seed} step {step}");
            let op = rng.random_range(0..100);
            if op < 50 && t.is_finite() {
                now = t;
                times[i] = round(now + wait.sample(&mut rng));
                cal.update(i, times[i]);
                for _ in 0..rng.random_range(0..3) {
                    let j = rng.random_range(0..n);
                    times[j] = round(now + wait.sample(&mut rng));
                    cal.update(j, times[j]);
                }
            } else if op < 70 {
                // A kick between now and the minimum, then an early event.
                if t.is_finite() {
                    now = rng.random_range(now..=t);
                }
                let j = rng.random_range(0..n);
                times[j] = round(now + 0.1 * wait.sample(&mut rng)).max(now);
                cal.update(j, times[j]);
            } else if op < 80 {
                // Far ahead: many calendar years.
                let j = rng.random_range(0..n);
                times[j] = round(now + 1e3 * n as f64 * wait.sample(&mut rng));
                cal.update(j, times[j]);
            } else if op < 95 {
                let j = rng.random_range(0..n);
                times[j] = f64::INFINITY;
                cal.update(j, times[j]);
            } else if op == 95 {
                for (j, tj) in times.iter_mut().enumerate() {
                    if rng.random_range(0..4) == 0 {
                        *tj = round(now + wait.sample(&mut rng));
                    }
                    cal.set_lazy(j, *tj);
                }
                cal.rebuild();
            } else {
                // Reschedule the minimum in place (stays in the current bucket).
                if t.is_finite() {
                    now = t;
                    times[i] = round(now + 1e-3 * mean_wait * wait.sample(&mut rng));
                    cal.update(i, times[i]);
                }
            }
            if step % 97 == 0 {
                cal.check()
                    .and_then(|()| members_match(&cal, &times))
                    .unwrap_or_else(|e| panic!("n {n} seed {seed} step {step}: {e}"));
            }
            assert_eq!(cal.time(i), times[i]);
        }
        cal.check().unwrap();
    }

    #[test]
    fn min_matches_brute_force_on_random_operations() {
        for (k, &n) in [2usize, 3, 17, 100, 1000, 3000].iter().enumerate() {
            let steps = if n > 1000 { 3000 } else { 6000 };
            // Continuous times, then coarse ones (frequent ties).
            against_brute_force(n, steps, 0.0, 1.0, 10 + k as u64);
            against_brute_force(n, steps, 0.25, 1.0, 20 + k as u64);
        }
    }

    #[test]
    fn edmd_pattern_spanning_many_years_matches_brute_force() {
        // Pop, reschedule by an exponential wait, update three others: the
        // minimum runs through many years, with rate changes forcing re-tuning.
        let n = 500;
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut times: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
        let mut cal = EventCalendar::new(n);
        for (i, &t) in times.iter().enumerate() {
            cal.set_lazy(i, t);
        }
        cal.rebuild();
        let dt0 = cal.bucket_width();
        let mut named = 0;
        for step in 0..60_000 {
            let (i, now) = brute_min(&times);
            assert_eq!(cal.min(), (i, now), "step {step}");
            // Rate 1 per particle, then 100 (a denser fluid), then 0.01.
            let rate = [1.0, 100.0, 0.01][step / 20_000];
            let wait = Exp::new(rate).unwrap();
            for j in [i, rng.random_range(0..n), rng.random_range(0..n)] {
                times[j] = now + wait.sample(&mut rng);
                cal.update(j, times[j]);
            }
            if step % 1000 == 0 {
                named += cal
                    .check()
                    .and_then(|()| members_match(&cal, &times))
                    .unwrap_or_else(|e| panic!("step {step}: {e}"));
            }
        }
        // ~2 events per bucket: the 60 checks saw ~600 named ahead.
        assert!(named > 200, "{named} particles named in buckets ahead");
        // The last phase is 100x sparser than the first: the width followed.
        assert!(
            cal.bucket_width() > 10.0 * dt0,
            "{} vs {dt0}",
            cal.bucket_width()
        );
    }

    #[test]
    fn rebuild_gives_the_brute_force_min() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for n in [2usize, 5, 64, 1000, 4097] {
            let mut times = vec![f64::INFINITY; n];
            let mut cal = EventCalendar::new(n);
            assert_eq!(cal.min(), brute_min(&times), "all infinite, n {n}");
            for round in 0..4 {
                for (i, slot) in times.iter_mut().enumerate() {
                    // Coarse times with ties, some infinite.
                    let t = match rng.random_range(0..10) {
                        0 => f64::INFINITY,
                        _ => rng.random_range(0..50) as f64 * 0.5 + round as f64,
                    };
                    *slot = t;
                    cal.set_lazy(i, t);
                }
                cal.rebuild();
                cal.check().unwrap();
                assert_eq!(cal.min(), brute_min(&times), "n {n} round {round}");
                for (i, &t) in times.iter().enumerate() {
                    assert_eq!(cal.time(i), t);
                }
            }
        }
    }

    #[test]
    fn all_infinite_and_back() {
        let mut cal = EventCalendar::new(4);
        cal.update(2, 5.0);
        cal.update(3, 5.0);
        assert_eq!(cal.min(), (2, 5.0));
        cal.update(2, f64::INFINITY);
        assert_eq!(cal.min(), (3, 5.0));
        cal.update(3, f64::INFINITY);
        assert_eq!(cal.min(), (0, f64::INFINITY));
        // A time far beyond the first year, then one before it.
        cal.update(1, 1e12);
        assert_eq!(cal.min(), (1, 1e12));
        cal.update(0, 7.0);
        assert_eq!(cal.min(), (0, 7.0));
        cal.check().unwrap();
        assert!(cal.bytes() >= 4 * 16);
    }
}
