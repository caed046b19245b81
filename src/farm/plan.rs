//! Which units of work a render takes: the frames asked for, and of them the K-th of N shards.

use crate::render::driver::Unit;
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// A part of a render: frames `frames` of the animation (half-open), shard `shard[0]` of
/// `shard[1]` of them (`[0, 1]`: all of them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Part {
    /// The frames `[start, end)` of the render, in animation frame numbers.
    pub frames: [u32; 2],
    /// `[k, n]`: the k-th (0-based) of n shards.
    pub shard: [u32; 2],
}

impl Part {
    /// The part of `frames` that shard `shard.0` of `shard.1` takes.
    pub fn new(frames: Range<u32>, shard: (u32, u32)) -> Part {
        Part {
            frames: [frames.start, frames.end],
            shard: [shard.0, shard.1],
        }
    }

    /// The part's frames as a range.
    pub fn frames(&self) -> Range<u32> {
        self.frames[0]..self.frames[1]
    }

    /// Whether the shards split whole frames (there are at least as many frames as shards)
    /// rather than every frame's samples.
    pub fn splits_frames(&self) -> bool {
        self.frames().len() >= self.shard[1] as usize
    }

    /// The units of this part, with `spp` samples per pixel in all. Frame shards are
    /// contiguous runs of frames; sample shards are contiguous runs of every frame's samples
    /// (and empty when there are more shards than samples).
    pub fn units(&self, spp: u32) -> Vec<Unit> {
        let [k, n] = self.shard.map(u64::from);
        let cut = |len: u64, i: u64| (len * i / n) as u32;
        let range = self.frames();
        if self.splits_frames() {
            let len = range.len() as u64;
            (range.start + cut(len, k)..range.start + cut(len, k + 1))
                .map(|frame| Unit {
                    frame,
                    samples: 0..spp,
                })
                .collect()
        } else {
            let samples = cut(spp as u64, k)..cut(spp as u64, k + 1);
            if samples.is_empty() {
                return vec![];
            }
            range
                .map(|frame| Unit {
                    frame,
                    samples: samples.clone(),
                })
                .collect()
        }
    }

    /// The units of every shard of the render this part belongs to.
    pub fn all_units(&self, spp: u32) -> Vec<Unit> {
        (0..self.shard[1])
            .flat_map(|k| {
                Part {
                    shard: [k, self.shard[1]],
                    ..*self
                }
                .units(spp)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_cover_the_work_once() {
        for frames in [0..1, 0..3, 2..9, 0..24] {
            for n in 1..=7 {
                for spp in [1, 4, 5, 64] {
                    let part = Part::new(frames.clone(), (0, n));
                    let mut units = part.all_units(spp);
                    units.sort();
                    let whole = Part::new(frames.clone(), (0, 1)).units(spp);
                    if part.splits_frames() {
                        assert_eq!(units, whole);
                    } else {
                        // Every frame's samples, once, in contiguous ranges.
                        for f in frames.clone() {
                            let mut at = 0;
                            for u in units.iter().filter(|u| u.frame == f) {
                                assert_eq!(u.samples.start, at);
                                at = u.samples.end;
                            }
                            assert_eq!(at, spp, "frames {frames:?} n {n} spp {spp}");
                        }
                    }
                }
            }
        }
    }
}
