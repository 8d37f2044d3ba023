//! The moves: `set` moves every named instance in parallel and makes its patches; the
//! transform, colour, view and culling setters.

use super::cull::{outside, Frustum};
use super::patches::Piece;
use super::types::{check_finite, CrowdError, InstanceId};
use super::Crowd;
use crate::deform::{rebuild_all, Lod, Strategy};
use crate::gpu::pose::clamp_t;
use crate::lodstrips::Survivors;
use crate::par;

/// Fewest slots per piece of work of `set`'s parallel pass: a moved instance there costs a
/// pose and a plan, one that steps or switches to its frame's tail a few microseconds more
/// (the move and its patches), so that smaller pieces cost more in handing out and in
/// patch lists than they gain.
const MOVES_PER_PIECE: usize = 16;

impl Crowd {
    /// Moves every instance of `moves` to its `(t, lod)` (as
    /// [`DeformingState::set`](crate::deform::DeformingState::set): `t` and LOD clamped, NaN
    /// refused), all in parallel, and sets its pose: `mix(V(0), V(1), t)`, or for an asset with a
    /// weight animation the track's weights at `t` (the 8 largest, see
    /// [`WEIGHT_SLOTS`](super::WEIGHT_SLOTS)), and makes the patches of its slots that the next
    /// `prepare` uploads. Everything is checked first: on error nothing moved. An instance named
    /// twice takes its last move.
    ///
    /// Where culling is on ([`set_culling`](Self::set_culling)), an instance out of the view
    /// set so far ([`set_view_proj`](Self::set_view_proj): set this frame's view first) is not
    /// drawn, so it moves to its frame's coarsest LOD instead of the one asked: far cheaper to
    /// keep (a tail list, no runtime), and the `set` that sees it in view moves it to the LOD
    /// asked before anything draws it.
    pub fn set(&mut self, moves: &[(InstanceId, f32, Lod)]) -> Result<(), CrowdError> {
        // What a move can be refused for (the LOD is resolved once, in the parallel pass).
        for &(id, t, lod) in moves {
            let a = self.member_asset(id)?;
            a.model.frame_at(t)?;
            lod.check()?;
        }
        let mut moved = vec![false; self.assets.len()];
        for &(id, t, lod) in moves {
            let a = &mut self.assets[id.asset as usize];
            if let Some(member) = &mut a.members[id.slot as usize] {
                member.pending = Some((t, lod));
            }
            a.dirty_poses.add(id.slot);
            moved[id.asset as usize] = true;
        }
        let path = self.path;
        let view_proj = glam::Mat4::from_cols_array_2d(&self.scene.view_proj);
        let frustum = (self.culling).then(|| Frustum::new(view_proj, self.scene.clock));
        for (a, _) in self.assets.iter_mut().zip(moved).filter(|(_, m)| *m) {
            let (model, track, layout, tails) = (&a.model, a.gpu.track(), &a.layout, &a.tails);
            let spares = &a.spares;
            let reach = (a.gpu.targets()).map_or(&[][..], |targets| targets.reach.as_slice());
            let bound = a.gpu.bound();
            let reach = (reach, a.gpu.stretch());
            let prepares = a.prepares;
            let lists = a.waiting.index_runs.len();
            // In parallel, in pieces of consecutive slots (a few a thread, so that pieces
            // with many frame switches even out): every moved instance's pose and plan; the
            // moves into a frame's tail list note the area they need; the moves that step or
            // rebuild from a frame's tail are made here, and the instance's patches right
            // after them; the rebuilds over the mesh are gathered.
            let per = par::piece_len(a.members.len(), MOVES_PER_PIECE);
            let parts: Vec<_> = (a.members.chunks_mut(per))
                .zip(a.poses.chunks_mut(per).zip(a.blocks.chunks(per)))
                .enumerate()
                .collect();
            let pieces = par::map(parts, |(k, (members, (poses, blocks)))| {
                let mut piece = Piece::default();
                let instances = members.iter_mut().zip(poses.iter_mut().zip(blocks));
                for (slot, (member, (pose, block))) in (k * per..).zip(instances) {
                    let Some(member) = member.as_mut() else {
                        continue;
                    };
                    let Some((t, lod)) = member.pending.take() else {
                        continue;
                    };
                    let t = clamp_t(t).expect("checked time");
                    pose.set_pose(track, t, &mut piece.weights);
                    // Checked above: cannot fail.
                    let k = model.frame_at(t).expect("checked time");
                    // Out of view: parked at the frame's coarsest LOD.
                    let hidden =
                        (frustum.as_ref()).is_some_and(|f| outside(f, (block, pose), bound, reach));
                    let lod = if hidden { Lod::Fraction(1.0) } else { lod };
                    let l = model.resolve(k, lod).expect("checked LOD");
                    if let Some(count) = tails.triangles(k, l) {
                        let at = (k, l, count);
                        member.enter_tail(slot as u32, at, (prepares, spares), &mut piece);
                        continue;
                    }
                    let state = member.leave_tail(model, spares);
                    let plan = state.plan_at(model, k, l, Strategy::Auto);
                    if plan.links_survivors(model) {
                        piece.rebuilds.push((slot, plan));
                        continue;
                    }
                    state.apply(model, plan, &mut Survivors::new());
                    member.patch(layout, slot as u32, prepares, &mut piece);
                }
                piece.runs()
            });
            let rebuilds = a.waiting.take(pieces);
            if !rebuilds.is_empty() {
                // The rebuilds over the mesh, by frame (instances switching to one frame
                // share its survivors), each instance's patches right after its rebuild.
                let mut plans = rebuilds.into_iter().peekable();
                let mut jobs = Vec::with_capacity(plans.len());
                for (slot, member) in a.members.iter_mut().enumerate() {
                    if let (Some(member), Some(&(s, plan))) = (member, plans.peek()) {
                        if s == slot {
                            jobs.push((plan, (slot as u32, member)));
                            plans.next();
                        }
                    }
                }
                let pieces = rebuild_all(
                    model,
                    &mut jobs,
                    |(_, member)| member.state.as_mut().expect("moved out of the tail lists"),
                    |(slot, member), piece: &mut Piece| {
                        member.patch(layout, *slot, prepares, piece);
                    },
                    Piece::runs,
                );
                a.waiting.take(pieces);
            }
            // settleAreas: serially, in slot order, each moved instance's area and record.
            let mut moved = std::mem::take(&mut a.waiting.moved);
            moved.sort_unstable();
            for &slot in &moved {
                a.settle(path, slot, lists);
            }
            moved.clear();
            a.waiting.moved = moved;
        }
        Ok(())
    }

    /// Sets an instance's object-to-world transform (finite): where it is at the crowd's
    /// clock now ([`set_clock`](Self::set_clock)); from there its velocity moves it on.
    pub fn set_transform(&mut self, id: InstanceId, model: glam::Mat4) -> Result<(), CrowdError> {
        check_finite("transform", &model.to_cols_array())?;
        let clock = self.scene.clock;
        let a = self.member_asset(id)?;
        let block = &mut a.blocks[id.slot as usize];
        block.set_model(model);
        block.motion[3] = clock;
        a.dirty_blocks.add(id.slot);
        Ok(())
    }

    /// Sets an instance's root motion (finite): from where it is at the crowd's clock now, it
    /// moves by `velocity` (world units per second of [`set_clock`](Self::set_clock)), on
    /// the GPU: walking costs no upload and no `set_transform` per frame. Zero (the default)
    /// keeps it still. Its transform ([`transform`](Self::transform)) is moved to where it
    /// is now.
    pub fn set_velocity(&mut self, id: InstanceId, velocity: glam::Vec3) -> Result<(), CrowdError> {
        check_finite("velocity", &velocity.to_array())?;
        let clock = self.scene.clock;
        let a = self.member_asset(id)?;
        let block = &mut a.blocks[id.slot as usize];
        block.set_model(block.model_at(clock));
        block.motion = [velocity.x, velocity.y, velocity.z, clock];
        a.dirty_blocks.add(id.slot);
        Ok(())
    }

    /// An instance's object-to-world transform at the crowd's clock now: the one set, moved
    /// by its velocity since.
    pub fn transform(&self, id: InstanceId) -> Result<glam::Mat4, CrowdError> {
        self.member(id)?;
        let block = &self.assets[id.asset as usize].blocks[id.slot as usize];
        Ok(block.model_at(self.scene.clock))
    }

    /// Sets the crowd's clock, in seconds (finite; default 0): the time root motion
    /// ([`set_velocity`](Self::set_velocity)) moves instances by, for drawing and culling.
    /// Set it each frame before `set`, as the view. It may run backwards; precision is f32's,
    /// counted from each instance's last placement, so an instance placed anew loses none.
    pub fn set_clock(&mut self, seconds: f32) -> Result<(), CrowdError> {
        check_finite("clock", &[seconds])?;
        self.scene.clock = seconds;
        self.scene_dirty = true;
        Ok(())
    }

    /// Sets an instance's colour (faceted and smooth modes; finite).
    pub fn set_color(&mut self, id: InstanceId, color: [f32; 4]) -> Result<(), CrowdError> {
        check_finite("colour", &color)?;
        let a = self.member_asset(id)?;
        a.blocks[id.slot as usize].color = color;
        a.dirty_blocks.add(id.slot);
        Ok(())
    }

    /// Sets projection * view for every instance.
    pub fn set_view_proj(&mut self, view_proj: glam::Mat4) {
        self.scene.view_proj = view_proj.to_cols_array_2d();
        self.scene_dirty = true;
    }

    /// Whether an instance out of view draws nothing (default: on). From the next prepare on,
    /// every prepare tests each instance's bounding sphere (its asset's poses, grown by its
    /// weights' reach, under its transform) against the view's clip volume and gives the
    /// record of an instance wholly outside it an instance count of 0 on the GPU. The test
    /// never culls an instance with a point in view, so the pixels do not change; the GPU
    /// skips the vertices, and `set` parks an instance out of view at its frame's coarsest LOD
    /// (its pose still follows its time), so that it costs next to no CPU either; the `set`
    /// that sees it in view again moves it to the LOD asked. Off: every instance at the LOD
    /// asked, every record as [`Crowd::at`] says.
    pub fn set_culling(&mut self, on: bool) {
        self.culling = on;
    }
}
