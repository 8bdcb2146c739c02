//! Levels of detail: a far groom simulates a nested fraction of its strands and carries the
//! rest along with their simulated neighbours.
//!
//! Level `L` simulates the first `⌈N / 2^L⌉` strands of a fixed order over the roots
//! (farthest-point: each next strand is the one farthest from those before it), so every
//! level's simulated strands are spread evenly over the scalp and include the next
//! level's. A strand that is not simulated *follows*: it keeps its own rest shape under the
//! head's pose, displaced as its three nearest simulated neighbours (by rest root) are
//! displaced from theirs, weighted by inverse distance: `x = pose(rest) + Σ wₖ (xₖ −
//! pose(restₖ))`. That is how a drawn child follows its guide, so a follower, like a child,
//! is not collided on its own.
//!
//! Switching does not pop. A strand that stops being simulated is stepped once more, then
//! placed where it would follow plus its offset from there, the offset shrinking by an
//! equal share each step of the fade. A strand that starts being simulated starts from
//! where it was drawn, moving as its leaders do, and is pulled back toward where it would
//! follow by a pull that lets go over the fade. Followers' segments keep the lengths
//! their placement gives them (holding them would cost a square root per particle, in a
//! chain); the solver restores a rising strand's.
//!
//! Placing a far head's followers is a pass over nearly all its particles, bound by memory.
//! A caller that copies the positions out anyway (the Bevy plugin, for drawing) can leave
//! the followers to that pass ([`Strands::fade_and_rise`](super::Strands::fade_and_rise),
//! [`Strands::head_space_followers`](super::Strands::head_space_followers)): in head space
//! a follower is its rest plus its leaders' weighted head-space displacement, with no pose
//! to apply.

use crate::math::{Pose, Vec3};
use glam::{Mat3A, Vec3A};

/// How many simulated neighbours a follower takes its motion from.
const LEADERS: usize = 3;

/// Deepest level of detail: 1/128 of the strands (at least one); 16 of 2,048, one SIMD
/// group, for a head some 30 pixels tall.
pub const MAX_DETAIL_LEVEL: u32 = 7;

/// A head drawn this many pixels tall or taller gets every strand by default
/// ([`level_for_height`]): about a head filling a third of a 1080-pixel-high view.
pub const FULL_DETAIL_HEIGHT: f32 = 360.0;

/// Strands simulated at `level` out of `strands`: `⌈strands / 2^level⌉`.
pub fn simulated_at_level(strands: usize, level: u32) -> usize {
    strands.div_ceil(1 << level.min(MAX_DETAIL_LEVEL)).min(strands)
}

/// The level of detail for a head drawn `height` pixels tall, when `full_detail_height`
/// pixels and more get every strand. The strands simulated follow the head's area on
/// screen: one level (half the strands) per factor √2 the height falls, at most
/// [`MAX_DETAIL_LEVEL`]. A groom switching between levels should hold its level until the
/// height moves past the boundary by some margin (see [`level_with_hysteresis`]).
pub fn level_for_height(height: f32, full_detail_height: f32) -> u32 {
    if height.is_nan() || height <= 0.0 {
        return MAX_DETAIL_LEVEL;
    }
    if full_detail_height.is_nan() || full_detail_height <= 0.0 {
        return 0;
    }
    let halvings_of_area = (2.0 * (full_detail_height / height).log2()).floor();
    halvings_of_area.clamp(0.0, MAX_DETAIL_LEVEL as f32) as u32
}

/// The tallest a head may be drawn at `level` ([`level_for_height`]'s bands run from
/// half as many pixels of area, exclusive, to this, inclusive).
fn band_top(level: u32, full_detail_height: f32) -> f32 {
    full_detail_height * 0.5f32.powf(level as f32 * 0.5)
}

/// [`level_for_height`], but a groom at `current` keeps it while the height is within
/// `margin` (a fraction, 0.1 = 10 %) of that level's band: a head hovering at a boundary
/// does not switch back and forth.
pub fn level_with_hysteresis(height: f32, full_detail_height: f32, current: u32, margin: f32) -> u32 {
    let wanted = level_for_height(height, full_detail_height);
    if wanted == current || margin.is_nan() || margin <= 0.0 {
        return wanted;
    }
    let (top, bottom) = (band_top(current, full_detail_height), band_top(current + 1, full_detail_height));
    let inside = (current == 0 || height <= top * (1.0 + margin))
        && (current >= MAX_DETAIL_LEVEL || height > bottom * (1.0 - margin));
    if inside { current } else { wanted }
}

/// What a strand does at the current level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Role {
    /// Stepped by the solver.
    Simulated,
    /// Leaving the simulation: stepped by the solver once more (while `left == total`),
    /// then placed as a follower offset by where the solver left it, the offset shrinking
    /// by `1 / total` of itself each step; `left` steps of that remain (0: the last is
    /// placed, and the strand follows from the next step on).
    Fading {
        /// Steps of the fade left.
        left: u32,
        /// Steps the fade takes.
        total: u32,
    },
    /// Placed from its leaders after each step.
    Following,
    /// Joining the simulation: stepped by the solver, then drawn back toward where it would
    /// follow by `(left - 1) / total` of the way, a pull that lets go over `total` steps.
    Rising {
        /// Steps of the rise left.
        left: u32,
        /// Steps the rise takes.
        total: u32,
    },
}

impl Role {
    /// Whether the solver steps the strand this step.
    pub(crate) fn stepped(self) -> bool {
        match self {
            Role::Simulated | Role::Rising { .. } => true,
            Role::Fading { left, total } => left == total,
            Role::Following => false,
        }
    }
}

/// Per strand, whom it follows: up to [`LEADERS`] simulated strands and their weights.
type Leaders = [(u32, f32); LEADERS];

/// No one to follow: a simulated strand's entry.
const NO_LEADERS: Leaders = [(0, 0.0); LEADERS];

/// The levels of detail of one groom: the nested order, the current level, each strand's
/// role and leaders.
#[derive(Clone, Debug)]
pub(crate) struct Detail {
    /// Strands in farthest-point order: level `L` simulates `order[..simulated_at_level(L)]`.
    order: Vec<u32>,
    /// Per strand, its position in `order`.
    rank: Vec<u32>,
    level: u32,
    pub(crate) roles: Vec<Role>,
    /// Per strand, its leaders at the current level (unused for simulated strands).
    leaders: Vec<Leaders>,
    /// Per level from 1, per strand, its leaders there (unused for the level's simulated
    /// strands).
    leaders_by_level: Vec<Vec<Leaders>>,
    /// Per particle of a fading strand, head-local: how far from where it would follow the
    /// solver left it (empty until a strand fades).
    offsets: Vec<Vec3>,
    /// Per particle of a rising strand: where it was at the start of the step.
    starts: Vec<Vec3>,
    /// Per particle, scratch: each leader's displacement from its rest under the pose.
    displacement: Vec<Vec3A>,
    /// The head's pose at the end of the step whose followers are not placed yet.
    pending: Option<Pose>,
}

impl Detail {
    /// The order over `roots` (head-local rest roots), every strand simulated.
    /// The order and every level's leaders are found here, once (O(N²) in the strand
    /// count), so that switching levels costs no search.
    pub(crate) fn new(roots: &[Vec3]) -> Self {
        let order = farthest_point_order(roots);
        let mut rank = vec![0; roots.len()];
        for (r, &s) in order.iter().enumerate() {
            rank[s as usize] = r as u32;
        }
        let leaders_by_level = (1..=MAX_DETAIL_LEVEL)
            .map(|level| {
                let simulated = simulated_at_level(roots.len(), level);
                let leaders = &order[..simulated];
                let follows = |s: usize| rank[s] as usize >= simulated;
                let nearest = |s: usize| if follows(s) { nearest(roots[s], leaders, roots) } else { NO_LEADERS };
                crate::parallel::map(roots.len(), nearest)
            })
            .collect();
        Detail {
            order,
            rank,
            level: 0,
            roles: vec![Role::Simulated; roots.len()],
            leaders: Vec::new(),
            leaders_by_level,
            offsets: Vec::new(),
            starts: Vec::new(),
            displacement: Vec::new(),
            pending: None,
        }
    }

    /// The strands' space moved by `offset` ([`Strands::translate`](super::Strands::translate)).
    pub(crate) fn translate(&mut self, offset: Vec3) {
        self.starts.iter_mut().for_each(|p| *p += offset);
        if let Some(pose) = &mut self.pending {
            pose.translation += offset;
        }
    }

    /// Every strand was put at `positions`, motionless: a rising strand starts its next
    /// step from there.
    pub(crate) fn placed(&mut self, positions: &[Vec3]) {
        self.pending = None;
        if self.starts.len() == positions.len() {
            self.starts.copy_from_slice(positions);
        }
    }

    /// Gives each follower its leaders' velocity, weighted as its position is: how it is
    /// drawn moving (up to the head's turn between the roots), for a strand about to be
    /// simulated again.
    pub(crate) fn led_velocities(&self, n: usize, velocities: &mut [Vec3]) {
        for (s, role) in self.roles.iter().enumerate() {
            if *role == Role::Following {
                for j in 1..n {
                    velocities[s * n + j] =
                        self.leaders[s].iter().map(|&(k, w)| velocities[k as usize * n + j] * w).sum();
                }
            }
        }
    }

    pub(crate) fn level(&self) -> u32 {
        self.level
    }

    /// Goes to `level`: strands that stop being simulated fade out over `fade_steps`
    /// steps, strands that start being simulated rise into it over as many (0: both at
    /// once, which pops), and followers get the new level's leaders. `positions` (world,
    /// strand-major) are where the strands are drawn now. Returns the strands that start
    /// being simulated, for the caller to clear their solver memory.
    pub(crate) fn set_level(&mut self, level: u32, fade_steps: u32, positions: &[Vec3]) -> Vec<usize> {
        let level = level.min(MAX_DETAIL_LEVEL);
        let simulated = simulated_at_level(self.order.len(), level) as u32;
        let n = positions.len() / self.order.len().max(1);
        let mut started = Vec::new();
        for (s, role) in self.roles.iter_mut().enumerate() {
            let keep = self.rank[s] < simulated;
            let fade = Role::Fading { left: fade_steps, total: fade_steps };
            *role = match (*role, keep) {
                (Role::Simulated | Role::Rising { .. }, true) => *role,
                (Role::Fading { left, total }, true) if left == total => Role::Simulated,
                (_, true) => {
                    started.push(s);
                    if fade_steps == 0 {
                        Role::Simulated
                    } else {
                        if self.starts.len() != positions.len() {
                            self.starts.resize(positions.len(), Vec3::ZERO);
                        }
                        self.starts[s * n..(s + 1) * n].copy_from_slice(&positions[s * n..(s + 1) * n]);
                        Role::Rising { left: fade_steps, total: fade_steps }
                    }
                }
                (_, false) if fade_steps == 0 => Role::Following,
                (Role::Simulated | Role::Rising { .. }, false) => fade,
                (Role::Fading { .. } | Role::Following, false) => *role,
            };
        }
        self.level = level;
        let before = std::mem::take(&mut self.leaders);
        let now = if level == 0 { None } else { Some(&self.leaders_by_level[level as usize - 1]) };
        self.leaders = (0..self.roles.len())
            .map(|s| match self.roles[s] {
                Role::Simulated => NO_LEADERS,
                // A rising strand is pulled toward where it would have followed: its
                // leaders stay (simulated at every finer level too).
                Role::Rising { .. } => before.get(s).copied().unwrap_or(NO_LEADERS),
                _ => now.map_or(NO_LEADERS, |leaders| leaders[s]),
            })
            .collect();
        started
    }

    /// After a step: fades the strands leaving the simulation, pulls rising ones, and
    /// places the followers (or, with `place_followers` false, leaves them for
    /// [`Self::place_pending`] or [`Self::head_space_placement`]).
    /// A follower goes where its leaders' displacement puts its rest shape; a fading
    /// strand goes there plus what is left of its offset; and a rising strand, stepped, is
    /// drawn back toward there by what is left of its pull. The last two get the velocity of
    /// where they went from the step's start, so that they can be simulated (again) moving
    /// as they were drawn (a follower gets its leaders' when it rises).
    /// `positions` and `velocities` are world-space and strand-major, `rest` the rest
    /// shape's positions, `pose` the head's at the end of the step.
    #[allow(clippy::too_many_arguments)] // the strands' arrays, the step, and the choice
    pub(crate) fn follow(
        &mut self,
        n: usize,
        rest: &[Vec3],
        pose: &Pose,
        dt: f32,
        positions: &mut [Vec3],
        velocities: &mut [Vec3],
        place_followers: bool,
    ) {
        if self.roles.iter().all(|&r| r == Role::Simulated) {
            return;
        }
        // A fade placed its strand for the last time in the step before: it follows now.
        for role in &mut self.roles {
            if let Role::Fading { left: 0, .. } = role {
                *role = Role::Following;
            }
        }
        self.world_displacement(n, rest, pose, positions);
        let frame = (Mat3A::from_quat(pose.rotation), Vec3A::from(pose.translation));
        let mut pulled = false;
        let inverse_dt = if dt > 0.0 { dt.recip() } else { 0.0 };
        // Per particle of the strand at hand: where its leaders put it, where it goes, and
        // where the step started from.
        let (mut target, mut wanted, mut start) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        for s in 0..self.roles.len() {
            let strand = s * n..(s + 1) * n;
            let (rest, x, offsets) = (&rest[strand.clone()], &positions[strand.clone()], &self.offsets);
            let place = |out: &mut [Vec3]| followed(frame, n, self.leaders[s], &self.displacement, rest, out);
            let next = match self.roles[s] {
                // Followers are placed below, all at once.
                Role::Simulated | Role::Following => continue,
                Role::Fading { left, total } if left == total => {
                    // Just stepped: from here on, the offset from the target shrinks.
                    place(&mut target);
                    self.offsets.resize(positions.len(), Vec3::ZERO);
                    for j in 0..n {
                        self.offsets[s * n + j] = pose.rotation.inverse() * (positions[s * n + j] - target[j]);
                    }
                    self.roles[s] = Role::Fading { left: total - 1, total };
                    continue;
                }
                Role::Fading { left, total } => {
                    place(&mut target);
                    let share = left as f32 / total as f32;
                    for j in 0..n {
                        wanted[j] = target[j] + pose.rotation * offsets[s * n + j] * share;
                    }
                    start.copy_from_slice(x);
                    Role::Fading { left: left - 1, total }
                }
                Role::Rising { left, total } => {
                    place(&mut target);
                    let pull = (left - 1) as f32 / total as f32;
                    for j in 0..n {
                        wanted[j] = x[j] + (target[j] - x[j]) * pull;
                    }
                    start.copy_from_slice(&self.starts[strand.clone()]);
                    pulled = true;
                    if left > 1 { Role::Rising { left: left - 1, total } } else { Role::Simulated }
                }
            };
            self.roles[s] = next;
            // Lengths as they come, as a follower's: a rising strand's are the solver's to
            // restore, a little more each step as the pull lets go.
            for j in 0..n {
                let i = s * n + j;
                let placed = if j == 0 { target[0] } else { wanted[j] };
                velocities[i] = (placed - start[j]) * inverse_dt;
                positions[i] = placed;
            }
            if matches!(next, Role::Rising { .. }) {
                self.starts[strand.clone()].copy_from_slice(&positions[strand]);
            }
        }
        // The followers follow their leaders as drawn: after the pulls, which move leaders.
        if place_followers {
            if pulled {
                self.world_displacement(n, rest, pose, positions);
            }
            self.place_following(n, frame, rest, positions);
            self.pending = None;
        } else {
            self.pending = Some(*pose);
        }
    }

    /// Places the followers left unplaced by the last [`Self::follow`] where their leaders
    /// put them at the end of that step.
    pub(crate) fn place_pending(&mut self, n: usize, rest: &[Vec3], positions: &mut [Vec3]) {
        let Some(pose) = self.pending.take() else { return };
        self.world_displacement(n, rest, &pose, positions);
        let frame = (Mat3A::from_quat(pose.rotation), Vec3A::from(pose.translation));
        self.place_following(n, frame, rest, positions);
    }

    /// Places every follower under the pose `frame`, from `self.displacement`.
    fn place_following(&self, n: usize, frame: (Mat3A, Vec3A), rest: &[Vec3], positions: &mut [Vec3]) {
        // Where the leaders put each follower, lengths as they come: kept exactly, they
        // would chain each particle's square root onto its parent's (the solver restores
        // them once it rises). Its velocity is its leaders', taken when it rises
        // (`led_velocities`).
        for s in (0..self.roles.len()).filter(|&s| self.follows(s)) {
            let strand = s * n..(s + 1) * n;
            followed(frame, n, self.leaders[s], &self.displacement, &rest[strand.clone()], &mut positions[strand]);
        }
    }

    /// Whether strand `s` follows: placed from its leaders, neither stepped nor fading.
    #[inline]
    pub(crate) fn follows(&self, s: usize) -> bool {
        self.roles.get(s) == Some(&Role::Following)
    }

    /// Whether followers wait to be placed ([`Self::follow`] was told to leave them).
    pub(crate) fn pending(&self) -> bool {
        self.pending.is_some()
    }

    /// Each leader's displacement from its rest under `pose`, into `self.displacement`.
    fn world_displacement(&mut self, n: usize, rest: &[Vec3], pose: &Pose, positions: &[Vec3]) {
        self.leaders_displaced(n, positions.len(), |i| positions[i] - pose.transform_point(rest[i]));
    }

    /// `displacement(i)` for every particle `i` of the simulated strands (the leaders),
    /// into `self.displacement` (sized for `particles`).
    fn leaders_displaced(&mut self, n: usize, particles: usize, displacement: impl Fn(usize) -> Vec3) {
        let simulated = simulated_at_level(self.order.len(), self.level);
        self.displacement.resize(particles, Vec3A::ZERO);
        for &s in &self.order[..simulated] {
            let strand = s as usize * n..(s as usize + 1) * n;
            for (i, d) in strand.clone().zip(&mut self.displacement[strand]) {
                *d = displacement(i).into();
            }
        }
    }

    /// The followers' placement in head space, for a caller that copies the positions out
    /// itself: `local(i)` is particle `i`'s head-space position (asked of the simulated
    /// strands' particles only). A follower's head-space position is its rest plus its
    /// leaders' weighted head-space displacement, which the head's pose does not enter: the
    /// same placement as [`Self::place_pending`]'s, to rounding.
    pub(crate) fn head_space_placement<'a>(
        &'a mut self,
        n: usize,
        rest: &'a [Vec3],
        local: impl Fn(usize) -> Vec3,
    ) -> HeadSpaceFollowers<'a> {
        self.leaders_displaced(n, rest.len(), |i| local(i) - rest[i]);
        HeadSpaceFollowers { n, rest, detail: self }
    }
}

/// Places a level of detail's followers in head space
/// ([`Strands::head_space_followers`](super::Strands::head_space_followers)), strand by
/// strand, from any thread.
pub struct HeadSpaceFollowers<'a> {
    n: usize,
    rest: &'a [Vec3],
    detail: &'a Detail,
}

impl HeadSpaceFollowers<'_> {
    /// Whether strand `s` is a follower, to be placed here.
    #[inline]
    pub fn follows(&self, s: usize) -> bool {
        self.detail.follows(s)
    }

    /// Writes follower `s`'s head-space positions into `out`, one per particle of the
    /// strand.
    #[inline]
    pub fn place(&self, s: usize, out: &mut [Vec3]) {
        let (n, identity) = (self.n, (Mat3A::IDENTITY, Vec3A::ZERO));
        followed(identity, n, self.detail.leaders[s], &self.detail.displacement, &self.rest[s * n..][..n], out);
    }
}

/// Where a strand's particles follow: its rest positions `rest` under the pose
/// `(rotation, translation)`, each displaced as its leaders' particles are (their
/// `displacement`, strand-major, weighted), into `out`; the root stays on its rest.
#[inline(always)]
fn followed(
    (rotation, translation): (Mat3A, Vec3A),
    n: usize,
    leaders: Leaders,
    displacement: &[Vec3A],
    rest: &[Vec3],
    out: &mut [Vec3],
) {
    let [(a, wa), (b, wb), (c, wc)] = leaders;
    let of = |k: u32| &displacement[k as usize * n..][..n];
    let (a, b, c) = (of(a), of(b), of(c));
    out[0] = (rotation * Vec3A::from(rest[0]) + translation).into();
    for j in 1..n {
        let displaced = a[j] * wa + b[j] * wb + c[j] * wc;
        out[j] = (rotation * Vec3A::from(rest[j]) + translation + displaced).into();
    }
}

/// The strands in farthest-point order over their roots: the first is the one nearest the
/// roots' centroid, each next the one farthest from all before it (ties to the lower
/// index). O(N²), once per groom.
fn farthest_point_order(roots: &[Vec3]) -> Vec<u32> {
    let count = roots.len();
    if count == 0 {
        return Vec::new();
    }
    let centroid = roots.iter().copied().sum::<Vec3>() / count as f32;
    let first =
        (0..count).min_by(|&a, &b| roots[a].distance_squared(centroid).total_cmp(&roots[b].distance_squared(centroid)));
    let mut order = Vec::with_capacity(count);
    let mut nearest_chosen = vec![f32::INFINITY; count];
    let mut next = first.unwrap_or(0);
    for _ in 0..count {
        order.push(next as u32);
        let chosen = roots[next];
        nearest_chosen[next] = f32::NEG_INFINITY;
        let mut farthest = (f32::NEG_INFINITY, 0);
        for (s, d) in nearest_chosen.iter_mut().enumerate() {
            if *d == f32::NEG_INFINITY {
                continue;
            }
            *d = d.min(roots[s].distance_squared(chosen));
            if *d > farthest.0 {
                farthest = (*d, s);
            }
        }
        next = farthest.1;
    }
    order
}

/// The [`LEADERS`] strands of `leaders` whose roots are nearest `root`, weighted by inverse
/// distance (summing to 1); fewer leaders than that repeat the nearest with weight 0.
fn nearest(root: Vec3, leaders: &[u32], roots: &[Vec3]) -> Leaders {
    let mut best = [(u32::MAX, f32::INFINITY); LEADERS];
    for &k in leaders {
        let d = roots[k as usize].distance(root);
        if d < best[LEADERS - 1].1 {
            best[LEADERS - 1] = (k, d);
            best.sort_by(|a, b| a.1.total_cmp(&b.1));
        }
    }
    // Inverse distance, kept finite for a leader on the same root.
    let weights = best.map(|(k, d)| if k == u32::MAX { 0.0 } else { 1.0 / (d + 1e-4) });
    let total: f32 = weights.iter().sum();
    let nearest = best[0].0;
    std::array::from_fn(|i| {
        let (k, _) = best[i];
        if k == u32::MAX { (nearest, 0.0) } else { (k, weights[i] / total) }
    })
}

#[cfg(test)]
mod tests;
