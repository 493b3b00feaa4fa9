//! A bounded, deterministic, anytime solver for the open asymmetric TSP path with precedence
//! classes: the global tour of an exploration planner (FUEL, Zhou et al. 2021, a tour over the
//! frontier clusters; Gao et al.'s tour with precedence).
//!
//! **Problem.** Node 0 is the robot, the fixed start of the path; nodes `1..=n` are the tasks. The
//! path visits every task once and does not return. `cost[a][b]` is the cost from `a` to `b` (it
//! may differ from `cost[b][a]`); `u32::MAX` means unreachable and is simply a very large cost:
//! every sum is a `u64` (at most `MAX_TASKS + 1` terms of at most `u32::MAX`), so nothing
//! overflows, and a path that needs an unreachable leg is only chosen when every path does.
//!
//! **Precedence.** Each task has a class (`u8`); along the path the classes never decrease (the
//! robot's class is ignored). So a tour is a sequence of *class blocks* in ascending class order,
//! and the position range of each block is fixed by how many tasks each class has: a task of class
//! `c` can only stand inside block `c`. Every move below keeps the tasks inside their block.
//!
//! **Algorithm.**
//! 1. [`TourSolver::start`]: the warm order (an earlier tour; entries out of `1..=n` and repeats
//!    are skipped) is stably sorted by class, which keeps its order inside each class (hysteresis
//!    across replans). The tasks missing from it, appended to their block, give a first complete
//!    tour, so [`TourSolver::best`] is valid from the start.
//! 2. Construction: the missing tasks go into the warm order by *cheapest feasible insertion*:
//!    each round tries every missing task in every gap whose neighbours' classes allow it and
//!    inserts the cheapest (ties: lowest task index, then earliest gap). If the result is dearer
//!    than the tour of step 1, the search starts from that one instead.
//! 3. Local search, first improvement, in one fixed cyclic scan order: *2-opt* (reverse
//!    `seq[i..=j]` inside one class block; with asymmetric costs the reversed segment's cost is
//!    summed exactly, incrementally as `j` grows), then *Or-opt* (move 1, 2 or 3 consecutive tasks
//!    of one block to another gap of that block, forwards and, for 2 or 3 tasks, reversed, again
//!    with the exact reversed cost). An improving move is applied at once and the scan goes on
//!    from the next candidate; a descent ends when a whole neighbourhood (`N` candidates in a row)
//!    brings no improvement: a local optimum.
//! 4. Kicks (iterated local search): [`KICKS`] times, go back to the best tour if the last
//!    descent ended above it, rotate two short windows (at most 8 tasks, each inside one block:
//!    an exchange of two adjacent segments, orientation kept) chosen by a fixed-seed xorshift32
//!    ([`crate::rrt::xorshift32`]), and descend again; the best tour is kept. Without the kicks a
//!    task that should end block `c` and one that should start block `c + 1` can only change
//!    together, which no single move does (the brute-force test: worst ratio 1.36 without kicks,
//!    1.10 with). The solve ends after the last kick's descent, or after
//!    [`MAX_IMPROVING_MOVES`] improving moves in all (a backstop, not reached in the tests).
//!
//! **Work and resumption.** [`TourSolver::step`] does at most `budget` *work units* and returns.
//! A unit is one insertion gap tried, one insertion done, one candidate move evaluated (a few
//! cost look-ups: the 2-opt segment sums are carried along the scan), one move applied or one
//! kick (at most [`MAX_TASKS`] byte moves and cost look-ups). All state — the construction
//! cursor, the scan cursor, the running segment sums, a found move waiting to be applied, the kick
//! generator — lives in the solver, so a solve can be spread over control ticks, and the sequence
//! of units, hence the final tour, does not depend on how the budget is sliced. [`TourSolver::start`]
//! does `n` units (the first tour's cost) plus an `O(n²)` byte sort it does not count.
//!
//! Per replan, with `n` tasks in one class block (the worst case): construction
//! `C(n + 2, 3) + n` units (19 648 for `n = 48`); a neighbourhood of
//! `N = n(n−1)/2 + n(n−1) + 2(n−1)(n−2) + 2(n−2)(n−3)` candidates (11 848 for `n = 48`); at most
//! `N` evaluations before each improving move, each kick and the end, so the search takes at
//! most `(M + K + 1)·N + M + K` units with `M` = [`MAX_IMPROVING_MOVES`], `K` = [`KICKS`].
//! [`MAX_SOLVE_WORK`] = 9 415 952 is the whole sum for `n = MAX_TASKS`: the hard worst case per
//! replan. Measured on 60 random 48-task instances (1–3 classes): mean 324 407 units, max
//! 663 828, at most 381 improving moves. Time: `O(n³)` construction, `O(n²)` per descent step.
//!
//! **Memory.** [`TourProblem`] is 9 664 bytes on a 64-bit host, 9 660 on `thumbv7em` (the
//! `(MAX_TASKS + 1)²` cost matrix); [`TourSolver`] is 448 bytes on a 64-bit host, 384 on
//! `thumbv7em` (all scratch inside, no allocation; the `sizes` test checks the host figures).

use crate::capacity::MAX_TASKS;
use crate::rrt::xorshift32;

/// Kicks (a perturbation of the best tour and a new descent) after the first local optimum.
pub const KICKS: u32 = 24;
/// The most tasks one kick's rotation moves (a local perturbation: the next descent is short).
const KICK_SPAN: usize = 8;
/// The kicks' xorshift32 seed (fixed: the same problem always gives the same tour).
const KICK_SEED: u32 = 0x2545_F491;

/// The cap on improving moves the local search applies per solve (it ends after this many even if
/// it could still improve): it makes [`MAX_SOLVE_WORK`] a hard bound.
pub const MAX_IMPROVING_MOVES: u32 = 16 * MAX_TASKS as u32;

/// Candidates in the largest neighbourhood (one class block of `n` tasks): 2-opt pairs plus
/// Or-opt moves of 1, 2 and 3 tasks (the last two in both orientations).
const fn neighbourhood_of_block(b: usize) -> u32 {
    let mut total = b * b.saturating_sub(1) / 2;
    let mut l = 1;
    while l <= 3 {
        if b > l {
            total += (b - l + 1) * (b - l) * if l >= 2 { 2 } else { 1 };
        }
        l += 1;
    }
    total as u32
}

/// Construction units from an empty warm order: `Σ_k (n − k)(k + 1)` gaps tried plus `n` insertions.
const fn construction_work(n: usize) -> u32 {
    let mut total = 0;
    let mut k = 0;
    while k < n {
        total += (n - k) * (k + 1) + 1;
        k += 1;
    }
    total as u32
}

/// The most work units one replan takes, `start` plus every `step` until done, for any problem
/// with at most [`MAX_TASKS`] tasks: `n` (start) + construction + `MAX_IMPROVING_MOVES·(N + 1) + N`.
pub const MAX_SOLVE_WORK: u32 = MAX_TASKS as u32
    + construction_work(MAX_TASKS)
    + (MAX_IMPROVING_MOVES + KICKS + 1) * neighbourhood_of_block(MAX_TASKS)
    + MAX_IMPROVING_MOVES
    + KICKS;

/// One tour problem. Node 0 is the robot (the path's fixed start); nodes `1..=n` are the tasks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TourProblem {
    /// Tasks, at most [`MAX_TASKS`] (more are ignored).
    pub n: usize,
    /// `cost[a][b]`: from node `a` to node `b` (asymmetric allowed); `u32::MAX` = unreachable.
    pub cost: [[u32; MAX_TASKS + 1]; MAX_TASKS + 1],
    /// Precedence class of each task: along the path classes never decrease (`class[0]` is ignored).
    pub class: [u8; MAX_TASKS + 1],
}

impl TourProblem {
    /// No tasks; every cost 0, every class 0.
    pub const fn new() -> Self {
        Self { n: 0, cost: [[0; MAX_TASKS + 1]; MAX_TASKS + 1], class: [0; MAX_TASKS + 1] }
    }

    #[inline]
    fn c(&self, a: u8, b: u8) -> u64 {
        self.cost[a as usize][b as usize] as u64
    }

    /// The cost of the path robot → `order[0]` → … → `order[last]`.
    pub fn path_cost(&self, order: &[u8]) -> u64 {
        let mut prev = 0;
        let mut total = 0;
        for &t in order {
            total += self.c(prev, t);
            prev = t;
        }
        total
    }

    /// True if the classes along `order` never decrease.
    pub fn respects_precedence(&self, order: &[u8]) -> bool {
        order.windows(2).all(|w| self.class[w[0] as usize] <= self.class[w[1] as usize])
    }
}

impl Default for TourProblem {
    fn default() -> Self {
        Self::new()
    }
}

/// A tour: the tasks in visiting order and the path's cost.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Tour {
    /// Task indices `1..=n` in visiting order.
    pub order: heapless::Vec<u8, MAX_TASKS>,
    /// Cost of the path from the robot through `order`.
    pub cost: u64,
}

impl Tour {
    /// Empty.
    pub const fn new() -> Self {
        Self { order: heapless::Vec::new(), cost: 0 }
    }
}

impl Default for Tour {
    fn default() -> Self {
        Self::new()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Cheapest insertion of the missing tasks.
    Construct,
    /// Local search; `pending` holds a found improving move.
    Search,
    /// At a local optimum: go back to the best tour and perturb it.
    Kick,
    /// Finished (or nothing to do).
    Done,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Reverse `seq[i..=j]`.
    TwoOpt,
    /// Move `seq[i..i + l]` into gap `j` (between `seq[j]` and `seq[j + 1]`), reversed if `rev`.
    OrOpt,
}

/// The local-search scan position (and the move to apply when one is pending).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Cursor {
    kind: Kind,
    i: usize,
    j: usize,
    l: usize,
    rev: bool,
}

/// The resumable solver. All scratch is inside; [`TourSolver::new`] is `const`.
pub struct TourSolver {
    phase: Phase,
    /// Tasks of the problem being solved.
    n: usize,
    /// The working path: `seq[0]` is the robot (0), `seq[1..=len]` the tasks.
    seq: [u8; MAX_TASKS + 1],
    len: usize,
    /// Cost of the working path.
    cost: u64,
    /// Tasks not yet in `seq`, ascending.
    missing: [u8; MAX_TASKS],
    n_missing: usize,
    /// Construction cursor: missing task `ct`, gap `cg`; the cheapest so far (delta, task slot, gap).
    ct: usize,
    cg: usize,
    c_best: (i64, usize, usize),
    /// First and last position of the class block of each position (fixed during the search).
    block_start: [u8; MAX_TASKS + 1],
    block_end: [u8; MAX_TASKS + 1],
    /// Candidates in a whole neighbourhood, candidates since the last improvement, moves applied.
    neighbourhood: u32,
    since: u32,
    moves: u32,
    /// Kicks done and to do; the kicks' xorshift32 state.
    kicks: u32,
    kick_limit: u32,
    rng: u32,
    cur: Cursor,
    /// 2-opt: cost of `seq[i..=j]` forwards and reversed.
    fwd: u64,
    bwd: u64,
    /// An improving move found and not yet applied: its cursor and the path's new cost.
    pending: Option<(Cursor, u64)>,
    best: Tour,
}

impl TourSolver {
    /// Idle, with an empty best tour.
    pub const fn new() -> Self {
        Self {
            phase: Phase::Done,
            n: 0,
            seq: [0; MAX_TASKS + 1],
            len: 0,
            cost: 0,
            missing: [0; MAX_TASKS],
            n_missing: 0,
            ct: 0,
            cg: 0,
            c_best: (i64::MAX, 0, 0),
            block_start: [0; MAX_TASKS + 1],
            block_end: [0; MAX_TASKS + 1],
            neighbourhood: 0,
            since: 0,
            moves: 0,
            kicks: 0,
            kick_limit: 0,
            rng: KICK_SEED,
            cur: Cursor { kind: Kind::TwoOpt, i: 0, j: 0, l: 0, rev: false },
            fwd: 0,
            bwd: 0,
            pending: None,
            best: Tour::new(),
        }
    }

    /// The best tour so far: after [`TourSolver::start`] always complete (every task once) and
    /// precedence-respecting.
    pub fn best(&self) -> &Tour {
        &self.best
    }

    /// True once the solve has finished (no improving move left, or the move cap reached).
    pub fn is_done(&self) -> bool {
        self.phase == Phase::Done
    }

    /// Starts a solve of `p`. `warm` is an earlier order, in task indices of this problem; entries
    /// outside `1..=n` and repeats are skipped, the rest keep their order within each class. The
    /// missing tasks are inserted by the following [`TourSolver::step`]s. Returns the work done
    /// (`n` units: the first tour's cost). `p` must not change until the solve is done.
    pub fn start(&mut self, p: &TourProblem, warm: &[u8]) -> u32 {
        let n = p.n.min(MAX_TASKS);
        self.n = n;
        let mut seen = [false; MAX_TASKS + 1];
        self.seq[0] = 0;
        self.len = 0;
        for &t in warm {
            if t >= 1 && (t as usize) <= n && !seen[t as usize] && self.len < n {
                seen[t as usize] = true;
                self.len += 1;
                self.seq[self.len] = t;
            }
        }
        // Stable insertion sort by class (at most MAX_TASKS² / 2 byte moves).
        for k in 2..=self.len {
            let t = self.seq[k];
            let mut m = k;
            while m > 1 && p.class[self.seq[m - 1] as usize] > p.class[t as usize] {
                self.seq[m] = self.seq[m - 1];
                m -= 1;
            }
            self.seq[m] = t;
        }
        self.n_missing = 0;
        for t in (1..=n).filter(|&t| !seen[t]) {
            self.missing[self.n_missing] = t as u8;
            self.n_missing += 1;
        }
        // The first complete tour: each missing task at the end of its class block.
        self.best.order.clear();
        for &t in &self.seq[1..=self.len] {
            let _ = self.best.order.push(t);
        }
        for &t in &self.missing[..self.n_missing] {
            let c = p.class[t as usize];
            let at = self.best.order.iter().filter(|&&u| p.class[u as usize] <= c).count();
            let _ = self.best.order.insert(at, t);
        }
        self.best.cost = p.path_cost(&self.best.order);
        self.cost = p.path_cost(&self.seq[1..=self.len]);
        self.phase = Phase::Construct;
        self.ct = 0;
        self.cg = 0;
        self.c_best = (i64::MAX, 0, 0);
        self.pending = None;
        self.moves = 0;
        self.since = 0;
        self.kicks = 0;
        self.kick_limit = KICKS;
        self.rng = KICK_SEED;
        if self.n_missing == 0 {
            self.finish_construction(p);
        }
        n as u32
    }

    /// Works for at most `budget` units (see the module documentation). Returns the units spent
    /// and whether the solve is done; once done, further calls spend nothing.
    pub fn step(&mut self, p: &TourProblem, budget: u32) -> (u32, bool) {
        debug_assert!(p.n.min(MAX_TASKS) == self.n, "the problem changed during a solve");
        let mut spent = 0;
        while spent < budget && self.phase != Phase::Done {
            match self.phase {
                Phase::Construct => self.construct_unit(p),
                Phase::Search => self.search_unit(p),
                Phase::Kick => self.kick_unit(p),
                Phase::Done => {}
            }
            spent += 1;
        }
        (spent, self.phase == Phase::Done)
    }

    /// One construction unit: try the current (task, gap), or insert the cheapest found.
    fn construct_unit(&mut self, p: &TourProblem) {
        if self.ct < self.n_missing {
            let t = self.missing[self.ct];
            let c = p.class[t as usize];
            let g = self.cg;
            let left_ok = g == 0 || p.class[self.seq[g] as usize] <= c;
            let right_ok = g == self.len || c <= p.class[self.seq[g + 1] as usize];
            if left_ok && right_ok {
                let a = self.seq[g];
                let (add, remove) = if g < self.len {
                    let b = self.seq[g + 1];
                    (p.c(a, t) + p.c(t, b), p.c(a, b))
                } else {
                    (p.c(a, t), 0)
                };
                let delta = add as i64 - remove as i64;
                if delta < self.c_best.0 {
                    self.c_best = (delta, self.ct, g);
                }
            }
            self.cg += 1;
            if self.cg > self.len {
                self.cg = 0;
                self.ct += 1;
            }
            return;
        }
        // Insert the cheapest: a feasible gap always exists (after the last task of class ≤ c).
        let (delta, slot, g) = self.c_best;
        let t = self.missing[slot];
        self.missing.copy_within(slot + 1..self.n_missing, slot);
        self.n_missing -= 1;
        self.seq.copy_within(g + 1..=self.len, g + 2);
        self.seq[g + 1] = t;
        self.len += 1;
        self.cost = (self.cost as i64 + delta) as u64;
        self.ct = 0;
        self.cg = 0;
        self.c_best = (i64::MAX, 0, 0);
        if self.n_missing == 0 {
            self.finish_construction(p);
        }
    }

    /// The constructed path is complete: keep the cheaper of it and the first tour, then set up
    /// the search (class blocks, neighbourhood size, the first candidate).
    fn finish_construction(&mut self, p: &TourProblem) {
        debug_assert_eq!(self.cost, p.path_cost(&self.seq[1..=self.len]));
        if self.cost <= self.best.cost {
            self.save_best();
        } else {
            self.seq[1..=self.len].copy_from_slice(&self.best.order);
            self.cost = self.best.cost;
        }
        let n = self.len;
        let mut s = 1;
        self.neighbourhood = 0;
        while s <= n {
            let c = p.class[self.seq[s] as usize];
            let mut e = s;
            while e < n && p.class[self.seq[e + 1] as usize] == c {
                e += 1;
            }
            for k in s..=e {
                self.block_start[k] = s as u8;
                self.block_end[k] = e as u8;
            }
            self.neighbourhood += neighbourhood_of_block(e - s + 1);
            s = e + 1;
        }
        self.since = 0;
        if self.neighbourhood == 0 {
            self.phase = Phase::Done;
            return;
        }
        self.phase = Phase::Search;
        self.first_candidate(p);
    }

    /// Puts the cursor on the first candidate of the neighbourhood (not empty).
    fn first_candidate(&mut self, p: &TourProblem) {
        if !self.two_opt_from(p, 1) {
            self.or_opt_next(p, Cursor { kind: Kind::OrOpt, i: 0, j: 0, l: 1, rev: false }, true);
        }
    }

    fn save_best(&mut self) {
        self.best.order.clear();
        let _ = self.best.order.extend_from_slice(&self.seq[1..=self.len]);
        self.best.cost = self.cost;
    }

    /// Puts the cursor on the first 2-opt pair `(i, i + 1)` with `i ≥ from` inside one block.
    fn two_opt_from(&mut self, p: &TourProblem, from: usize) -> bool {
        let mut i = from;
        while i < self.len {
            if i < self.block_end[i] as usize {
                let (a, b) = (self.seq[i], self.seq[i + 1]);
                self.cur = Cursor { kind: Kind::TwoOpt, i, j: i + 1, l: 0, rev: false };
                self.fwd = p.c(a, b);
                self.bwd = p.c(b, a);
                return true;
            }
            i += 1;
        }
        false
    }

    /// Moves the cursor to the Or-opt candidate after `c` (or, with `segment`, to the first gap
    /// of the next segment); after the last one, back to the first 2-opt pair.
    fn or_opt_next(&mut self, p: &TourProblem, c: Cursor, segment: bool) {
        let (mut l, mut i, mut g) = (c.l, c.i, c.j);
        if !segment {
            if !c.rev && l >= 2 {
                self.cur = Cursor { rev: true, ..c };
                return;
            }
            g += 1;
            if g + 1 == i {
                g = i + l;
            }
            if g <= self.block_end[i] as usize {
                self.cur = Cursor { kind: Kind::OrOpt, i, j: g, l, rev: false };
                return;
            }
        }
        loop {
            i += 1;
            if i + l - 1 > self.len {
                l += 1;
                i = 0;
                if l > 3 {
                    break;
                }
                continue;
            }
            let end = self.block_end[i] as usize;
            if i + l - 1 <= end {
                g = self.block_start[i] as usize - 1;
                if g + 1 == i {
                    g = i + l;
                }
                if g <= end {
                    self.cur = Cursor { kind: Kind::OrOpt, i, j: g, l, rev: false };
                    return;
                }
            }
        }
        // Wrap around (the neighbourhood is not empty, so this ends).
        self.first_candidate(p);
    }

    /// Moves the cursor to the next candidate.
    fn advance(&mut self, p: &TourProblem) {
        let c = self.cur;
        match c.kind {
            Kind::TwoOpt => {
                let j = c.j;
                if j < self.block_end[c.i] as usize {
                    let (a, b) = (self.seq[j], self.seq[j + 1]);
                    self.fwd += p.c(a, b);
                    self.bwd += p.c(b, a);
                    self.cur.j = j + 1;
                } else if !self.two_opt_from(p, c.i + 1) {
                    self.or_opt_next(p, Cursor { kind: Kind::OrOpt, i: 0, j: 0, l: 1, rev: false }, true);
                }
            }
            Kind::OrOpt => self.or_opt_next(p, c, false),
        }
    }

    /// The path's cost after the candidate at the cursor, if it is lower.
    fn evaluate(&self, p: &TourProblem) -> Option<u64> {
        let c = self.cur;
        let s = &self.seq;
        let n = self.len;
        let (old, new) = match c.kind {
            Kind::TwoOpt => {
                let (i, j) = (c.i, c.j);
                let (pre, first, last) = (s[i - 1], s[i], s[j]);
                let mut old = p.c(pre, first) + self.fwd;
                let mut new = p.c(pre, last) + self.bwd;
                if j < n {
                    old += p.c(last, s[j + 1]);
                    new += p.c(first, s[j + 1]);
                }
                (old, new)
            }
            Kind::OrOpt => {
                let (i, l, g) = (c.i, c.l, c.j);
                let e = i + l - 1;
                let (pre, s1, sl) = (s[i - 1], s[i], s[e]);
                let (mut inner_f, mut inner_b) = (0, 0);
                for k in i..e {
                    inner_f += p.c(s[k], s[k + 1]);
                    inner_b += p.c(s[k + 1], s[k]);
                }
                let (head, tail, inner) = if c.rev { (sl, s1, inner_b) } else { (s1, sl, inner_f) };
                let mut old = p.c(pre, s1) + inner_f;
                let mut new = inner;
                if e < n {
                    old += p.c(sl, s[e + 1]);
                    new += p.c(pre, s[e + 1]);
                }
                let a = s[g];
                new += p.c(a, head);
                if g < n {
                    old += p.c(a, s[g + 1]);
                    new += p.c(tail, s[g + 1]);
                }
                (old, new)
            }
        };
        (new < old).then(|| self.cost - (old - new))
    }

    /// One search unit: apply the pending move, or evaluate the candidate at the cursor.
    fn search_unit(&mut self, p: &TourProblem) {
        if let Some((c, cost)) = self.pending.take() {
            self.apply(c);
            self.cost = cost;
            debug_assert_eq!(self.cost, p.path_cost(&self.seq[1..=self.len]));
            debug_assert!(p.respects_precedence(&self.seq[1..=self.len]));
            if self.cost < self.best.cost {
                self.save_best();
            }
            self.moves += 1;
            if self.moves >= MAX_IMPROVING_MOVES {
                self.phase = Phase::Done;
                return;
            }
            self.advance(p);
            return;
        }
        if let Some(cost) = self.evaluate(p) {
            self.pending = Some((self.cur, cost));
            self.since = 0;
            return;
        }
        self.since += 1;
        if self.since >= self.neighbourhood {
            // A local optimum: a kick may have led straight to a better tour.
            if self.cost < self.best.cost {
                self.save_best();
            }
            self.phase = if self.kicks < self.kick_limit { Phase::Kick } else { Phase::Done };
            return;
        }
        self.advance(p);
    }

    /// One kick unit: back to the best tour if the last descent ended above it, then two random
    /// rotations `seq[x..=y]` (each inside one class block: an exchange of two adjacent segments,
    /// which keeps both orientations), and the search starts over from the first candidate.
    fn kick_unit(&mut self, p: &TourProblem) {
        if self.cost > self.best.cost {
            self.seq[1..=self.len].copy_from_slice(&self.best.order);
            self.cost = self.best.cost;
        }
        for _ in 0..2 {
            // A position in a block of two or more (one exists: the neighbourhood is not empty).
            let mut x = 1 + xorshift32(&mut self.rng) as usize % self.len;
            while self.block_start[x] == self.block_end[x] {
                x = x % self.len + 1;
            }
            let (s, e) = (self.block_start[x] as usize, self.block_end[x] as usize);
            let x = s + xorshift32(&mut self.rng) as usize % (e - s);
            let y = x + 1 + xorshift32(&mut self.rng) as usize % (e - x).min(KICK_SPAN - 1);
            let b = x + 1 + xorshift32(&mut self.rng) as usize % (y - x);
            self.seq[x..=y].rotate_left(b - x);
        }
        self.cost = p.path_cost(&self.seq[1..=self.len]);
        self.kicks += 1;
        self.since = 0;
        self.phase = Phase::Search;
        self.first_candidate(p);
    }

    fn apply(&mut self, c: Cursor) {
        match c.kind {
            Kind::TwoOpt => {
                self.seq[c.i..=c.j].reverse();
                core::mem::swap(&mut self.fwd, &mut self.bwd);
            }
            Kind::OrOpt => {
                let (i, l, g) = (c.i, c.l, c.j);
                let mut seg = [0u8; 3];
                seg[..l].copy_from_slice(&self.seq[i..i + l]);
                if c.rev {
                    seg[..l].reverse();
                }
                let at = if g < i {
                    // Shift seq[g + 1..i] right by l.
                    self.seq.copy_within(g + 1..i, g + 1 + l);
                    g + 1
                } else {
                    // Shift seq[i + l..=g] left by l.
                    self.seq.copy_within(i + l..=g, i);
                    g + 1 - l
                };
                self.seq[at..at + l].copy_from_slice(&seg[..l]);
            }
        }
    }
}

impl Default for TourSolver {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests;
