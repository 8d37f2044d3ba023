//! The slots' tests: uploads over walks against strips decoded on a simulated page.

use super::*;
use crate::deform::Lod;

/// A small grid morph with a few frames, so the walk switches frames.
fn model() -> DeformingModel {
    super::super::grid_model(7).1
}

/// The regions as built from scratch from the state's strips.
fn from_scratch(layout: &SlotLayout, state: &DeformingState) -> Vec<u32> {
    let mut slots = vec![RESTART; layout.regions() as usize];
    for r in 0..state.lengths().len() {
        let strip = state.strip(r).expect("strip");
        let start = layout.starts[r] as usize;
        strip.copy_to(&mut slots[start..start + strip.len()]);
    }
    slots
}

/// The triangles `words` draw as triangle strips cut by [`RESTART`] (odd triangles of a
/// strip flipped), degenerate ones left out, each turned to start at its least index
/// (orientation kept), sorted.
fn triangles(words: &[u32]) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    for strip in words.split(|&w| w == RESTART) {
        for (i, w) in strip.windows(3).enumerate() {
            let t = if i % 2 == 0 {
                [w[0], w[1], w[2]]
            } else {
                [w[1], w[0], w[2]]
            };
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                continue;
            }
            let m = (0..3).min_by_key(|&k| t[k]).expect("three");
            out.push([t[m], t[(m + 1) % 3], t[(m + 2) % 3]]);
        }
    }
    out.sort_unstable();
    out
}

/// The triangles of the state's strips, each decoded on its own.
fn reference(state: &DeformingState) -> Vec<[u32; 3]> {
    let mut out: Vec<[u32; 3]> = (0..state.lengths().len())
        .flat_map(|r| triangles(&state.strip(r).expect("strip").to_vec()))
        .collect();
    out.sort_unstable();
    out
}

/// Never written: a word read but never written would draw this vertex.
const POISON: u32 = 0xDEAD_BEEF;

/// One instance's area on a simulated page: moved to a new area (after a gap) wherever an
/// upload needs one, as the crowd's pool does; words outside its area stay [`POISON`].
struct Gpu {
    words: Vec<u32>,
    /// Its area's first word and words, and what it holds.
    area: Option<(u32, u32)>,
    holds: DrawnFrom,
    /// The dirty-log scratch, reused over a walk as a crowd's piece reuses it.
    dirty: Dirty,
    /// Areas made anew that kept words of the old one (a copy grown past its area).
    grown: usize,
}

impl Gpu {
    fn new() -> Gpu {
        Gpu {
            words: Vec::new(),
            area: None,
            holds: DrawnFrom::S0,
            dirty: Dirty::default(),
            grown: 0,
        }
    }

    fn held(&self) -> (DrawnFrom, u32) {
        (self.holds, self.area.map_or(0, |(_, words)| words))
    }

    /// What the crowd does with `need` before the patches apply: the area is kept where
    /// it holds the same and has `min..=max` words; else a new one of `room` words takes
    /// the old one's first `keep` words (restarts everywhere for regions), and the old
    /// one's words are poisoned (freed).
    fn settle(&mut self, need: Need) {
        assert!(need.min <= need.room && need.min <= need.max, "{need:?}");
        let fits = self
            .area
            .is_some_and(|(_, words)| need.keeps(self.holds, words));
        if !fits {
            // The pool rounds areas up to its granule.
            let room = need.room.next_multiple_of(GRANULE);
            let at = self.words.len() as u32 + 7;
            self.words.resize((at + room) as usize, POISON);
            let new = at as usize..(at + room) as usize;
            if need.holds == DrawnFrom::Regions {
                self.words[new.clone()].fill(RESTART);
            }
            if let Some((old, words)) = self.area {
                assert!(need.keep <= words, "{need:?}: keeps more than the old area");
                let old = old as usize..(old + words) as usize;
                let keep = need.keep as usize;
                self.words
                    .copy_within(old.start..old.start + keep, new.start);
                self.grown += usize::from(keep > 0);
                self.words[old].fill(POISON);
            } else {
                assert_eq!(need.keep, 0, "nothing to keep");
            }
            self.area = Some((at, room));
        }
        self.holds = need.holds;
    }

    /// Applies `patches` (words of the area) in reverse order (any order must do), each
    /// word once, every one within the area.
    fn apply(&mut self, patches: &[[u32; 2]]) {
        let mut words: Vec<u32> = patches.iter().map(|p| p[0]).collect();
        words.sort_unstable();
        words.dedup();
        assert_eq!(words.len(), patches.len(), "a word patched twice");
        let (at, size) = self.area.expect("an area");
        for &[word, value] in patches.iter().rev() {
            assert!(word < size, "word {word} past the area's {size}");
            self.words[(at + word) as usize] = value;
        }
    }

    fn read(&self, record: SlotRecord) -> &[u32] {
        let (at, size) = self.area.expect("an area");
        assert!(
            record.first + record.count <= size,
            "{record:?} past the area"
        );
        &self.words[(at + record.first) as usize..][..record.count as usize]
    }
}

/// One upload of `state`'s changes, checked: the area is settled and patched as the crowd
/// does, and the record draws exactly the state's triangles (with parity) and no word
/// never written; where the area holds the regions they are the regions built from
/// scratch, with nothing before the first live index or after the last; it holds the
/// compact copy exactly where the packed strips fit the share, and the record then reads
/// at most the read bound.
fn upload_checked(
    layout: &SlotLayout,
    state: &mut DeformingState,
    places: &mut Places,
    uploaded: &mut Vec<u32>,
    gpu: &mut Gpu,
    step: usize,
) -> DrawnFrom {
    let mut patches = Vec::new();
    let (record, need) = layout.upload(
        gpu.held(),
        state,
        places,
        uploaded,
        &mut gpu.dirty,
        &mut patches,
    );
    gpu.settle(need);
    gpu.apply(&patches);
    let read = gpu.read(record);
    assert!(!read.contains(&POISON), "step {step}: a word never written");
    assert_eq!(triangles(read), reference(state), "step {step}");
    // The packed count from the lengths themselves, not the state's running counts.
    let lengths = state.lengths();
    let packed = (lengths
        .iter()
        .filter(|&&n| n != 0)
        .map(|&n| n + 1)
        .sum::<u32>())
    .saturating_sub(1);
    assert_eq!(packed, super::packed(state));
    let compact = need.holds == DrawnFrom::Copy;
    assert_eq!(compact, packed <= layout.compact_slots());
    if compact {
        assert!(record.count >= packed);
        assert!(
            record.count <= packed * READ_BOUND_EIGHTHS / 8,
            "step {step}"
        );
        assert!(uploaded.is_empty(), "regions given up");
    } else {
        let (at, size) = gpu.area.expect("an area");
        assert!(size >= layout.regions());
        let regions = &gpu.words[at as usize..(at + layout.regions()) as usize];
        assert_eq!(
            regions,
            from_scratch(layout, state).as_slice(),
            "step {step}"
        );
        assert_eq!(uploaded.as_slice(), state.lengths());
    }
    assert!(read.first() != Some(&RESTART) && read.last() != Some(&RESTART));
    need.holds
}

/// Over a walk with frame switches and LOD jumps (moves accumulating between uploads),
/// the record draws the state's strips: from the compact copy exactly where they fit it,
/// else from the regions, which are then those built from scratch.
#[test]
fn patches_bring_the_slots_to_the_current_strips() {
    let model = model();
    for share in [0.0, 0.3, 1.0] {
        let layout = SlotLayout::new(&model, share);
        let mut state = DeformingState::new(&model);
        let mut gpu = Gpu::new();
        let mut places = Places::default();
        // As `Crowd::add` makes it: no regions.
        let mut uploaded = Vec::new();
        let walk = [
            (0.0, 0.5),
            (0.0, 0.9),
            (0.7, 0.9),
            (0.7, 0.1),
            (1.0, 1.0),
            (0.2, 0.0),
            (0.4, 0.6),
        ];
        let mut compacted = 0;
        for (step, &(t, lod)) in walk.iter().enumerate() {
            state.set(&model, t, Lod::Fraction(lod)).expect("set");
            // Every other step moves twice before the upload: the dirty log accumulates.
            if step % 2 == 1 {
                state.set(&model, 1.0 - t, Lod::Fraction(0.3)).expect("set");
            }
            let holds = upload_checked(
                &layout,
                &mut state,
                &mut places,
                &mut uploaded,
                &mut gpu,
                step,
            );
            compacted += usize::from(holds == DrawnFrom::Copy);
        }
        // Without a compact area never; with one as large as the regions always.
        assert_eq!(compacted == 0, share == 0.0);
        if share == 1.0 {
            assert_eq!(compacted, walk.len());
        }
    }
}

/// Over a long random walk (small LOD steps up and down, jumps, frame switches) every
/// way a strip of the compact copy moves happens, each upload checked as above: a move
/// within its room, to the end of the used part, a death, a birth, a repack, and records
/// going back to the regions and to the copy again.
#[test]
fn places_follow_a_long_random_walk() {
    let model = model();
    let layout = SlotLayout::new(&model, 0.6);
    let mut state = DeformingState::new(&model);
    let mut gpu = Gpu::new();
    let mut places = Places::default();
    let mut uploaded = Vec::new();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut random = move || crate::random::next_unit(&mut seed) as f32;
    let (mut t, mut lod) = (0.0f32, 0.5f32);
    let (mut within, mut to_end, mut deaths, mut births, mut back) = (0, 0, 0, 0, 0);
    let mut was_compact = false;
    for step in 0..400 {
        let roll = random();
        if roll < 0.1 {
            lod = random();
        } else {
            lod = (lod + 0.08 * (random() - 0.5)).clamp(0.0, 1.0);
        }
        if roll > 0.7 {
            t = random();
        }
        state.set(&model, t, Lod::Fraction(lod)).expect("set");
        let strips = state.lengths().len();
        let before = places.dense(strips);
        let (repacks, current) = (places.repacks, places.current);
        let compact = upload_checked(
            &layout,
            &mut state,
            &mut places,
            &mut uploaded,
            &mut gpu,
            step,
        ) == DrawnFrom::Copy;
        back += usize::from(was_compact && !compact);
        was_compact = compact;
        if !(compact && current && places.repacks == repacks) {
            continue;
        }
        for (old, now) in before.iter().zip(&places.dense(strips)) {
            let (at, len, new) = (old.at, old.len, now.len);
            within += usize::from(at == now.at && len != new && len > 0 && new > 0);
            to_end += usize::from(at != now.at && len > 0);
            deaths += usize::from(len > 0 && new == 0);
            births += usize::from(len == 0 && new > 0);
        }
    }
    let counts = [
        gpu.grown,
        within,
        to_end,
        deaths,
        births,
        places.repacks as usize,
        back,
    ];
    assert!(counts.iter().all(|&n| n > 0), "{counts:?}");
}
